//! The depth state of one command buffer, and what must be sent down for its next draw.
//!
//! The application's depth-related state (viewports, compare op, depth bias, depth bounds)
//! goes through here: its `vkCmdSet*` calls are recorded, the pipeline it binds brings its
//! static values (for the states revz made dynamic), and after every command that may change
//! what the next draw needs, [`CommandState::settle`] sends the values for the current depth
//! attachment: flipped when it is reversed, as the application gave them otherwise, only what
//! changed, and only inside a pass (outside one no draw can follow before the next begin,
//! which settles again). Draws therefore need nothing from revz and are not intercepted (the
//! depth profile hooks them to count, [`CommandState::before_draw`]). No Vulkan calls are made
//! here: emission goes through a [`StateSink`], so the logic is tested without a device.
//!
//! The draw's path (`shared/DESIGN.md` section 2) is decided here too: a draw into a reversed
//! attachment whose pipeline reads its projection from push constants, whose vertex stage
//! stores the carrier's depth ([`PipelineDepth::position_store`]), and whose pushed matrix is a
//! standard perspective of a known camera ([`crate::precise`]), takes the precise path: the
//! carrier holds the camera's reversed depth line (pushed when it changes) and the viewport maps
//! [a, b] -> [1-b, 1-a]. Every other draw into a reversed attachment takes the flip path, and
//! every draw of such a pipeline elsewhere gets the carrier that keeps the shader's own z.
//!
//! The fragment stage of a draw that computes with depth is swapped the same way: the bound
//! pipeline's reversed variant, or the bound fragment shader object's
//! (`VK_EXT_shader_object`, `crate::hooks::shader_object`), is bound in its place for a
//! reversed target and the application's back for a native one, each only when it changes.
//!
//! Files: this one is the state machine itself, the record and every transition (about 900
//! lines: one concern, whose transitions read each other's fields, and reads better whole);
//! [`pipeline_depth`] what a pipeline brings to it; `emission` what was last sent and the filter
//! that drops repeats; `app_viewports` the application's viewports and how each path maps them;
//! `known_pipelines` the pipelines a recording bound, found by handle; `tests` its tests.

use ash::vk;
use revz_math::{Cameras, DepthConvention, Target as RewriteTarget};

use crate::conv::{flip_compare_op, DepthBias, Reversal};
use crate::objects::{FragmentShader, PositionShader};
use crate::precise::{
    Carrier, FoldedPush, Outcome, ProjectionUse, PushConstants, PushSink, FLIP_CARRIER,
};
use crate::profile::{DrawCounts, DrawTally};

mod app_viewports;
mod emission;
mod known_pipelines;
pub mod pipeline_depth;
mod push_shortcut;
#[cfg(test)]
mod tests;

use app_viewports::AppViewports;
use emission::{Emitted, Filtered};
use known_pipelines::KnownPipelines;
pub use pipeline_depth::{DepthClip, PipelineDepth, States, MAX_VIEWPORTS};
use push_shortcut::PushShortcut;

/// The depth attachment draws currently go to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Target {
    /// Outside a render pass, or an attachment without depth.
    #[default]
    None,
    Native,
    Reversed,
}

/// The carrier of a draw whose vertex stage derives its range (`crate::shader::derived_range`): the
/// selector of the mode in w (1 complementary, 2 infinite); the rest is unused.
/// 3 and 4 are the same for a line fitted in [-1, 1] clip depth (the stage converts it to
/// [0, 1], which revz sets for the draw).
pub fn derived_selector(target: RewriteTarget, convention: DepthConvention) -> [f32; 4] {
    let gl = match convention {
        DepthConvention::ZeroToOne => 0.0,
        DepthConvention::NegativeOneToOne => 2.0,
    };
    match target {
        RewriteTarget::Complementary => [0.0, 0.0, 0.0, 1.0 + gl],
        RewriteTarget::Infinite => [0.0, 0.0, 0.0, 2.0 + gl],
    }
}

/// Whether two n / f ratios are the same camera's. The matrices of one camera (P * V * M,
/// one per object) recover n and f only to float32 noise, about 1e-6 relative: following that
/// noise would re-emit state for every draw, and move flip-path depths by less than they can
/// resolve.
pub fn same_near_over_far(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-4 * a.abs().max(b.abs())
}

/// Which path the last emitted state was for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DrawPath {
    /// Not into a reversed attachment: the application's state as it is.
    #[default]
    Native,
    Flip,
    Precise,
}

/// How a command buffer's reversed draws are made: the device's mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reversing {
    /// The projection rewrite (complementary and infinite modes); `None` in flip mode.
    pub rewrite: Option<RewriteTarget>,
    /// The map of standard depth onto the attachment, for the state the rewrite cannot reach.
    pub reversal: Reversal,
}

impl Reversing {
    /// What a vertex stage that derives its range (`crate::shader::derived_range`) stores.
    ///
    /// In infinite mode with no n / f known to the CPU (no camera pushed yet, or none ever:
    /// every projection in a buffer, as through Zink), the stage stores complementary depth
    /// 1 - D, not n / w. Everything else on the attachment maps with n / f = 0 then (flip-path
    /// viewports, clears, bounds, and copies and read twin refreshes converting back), and for
    /// that map 1 - D is exact where n / w is (1 - n / f) D off: what shaders and copies read
    /// comes back standard. With n / f = 0 both maps agree where the far plane is at infinity,
    /// and complementary keeps the application's far plane, as the flip path does.
    #[inline]
    pub fn derived_target(&self) -> Option<RewriteTarget> {
        match (self.rewrite?, self.reversal) {
            (RewriteTarget::Infinite, Reversal::Infinite { near_over_far: 0.0 }) => {
                Some(RewriteTarget::Complementary)
            }
            (target, _) => Some(target),
        }
    }
}

impl Default for Reversing {
    fn default() -> Self {
        Reversing {
            rewrite: None,
            reversal: Reversal::Complementary,
        }
    }
}

/// The shader stages whose `Position` may be rasterized, latest last: with shader objects the
/// last of them bound is (a mesh shader, where one is bound: the others are then unbound for
/// any valid draw).
pub const POSITION_STAGES: [vk::ShaderStageFlags; 4] = [
    vk::ShaderStageFlags::VERTEX,
    vk::ShaderStageFlags::TESSELLATION_EVALUATION,
    vk::ShaderStageFlags::GEOMETRY,
    vk::ShaderStageFlags::MESH_EXT,
];

/// Where [`CommandState::before_draw`] sends state (the next layer, in production).
pub trait StateSink: PushSink {
    fn set_viewports(&mut self, first: u32, viewports: &[vk::Viewport]);
    fn set_viewports_with_count(&mut self, viewports: &[vk::Viewport]);
    fn set_compare_op(&mut self, op: vk::CompareOp);
    fn set_bias(&mut self, bias: DepthBias);
    fn set_bounds(&mut self, min: f32, max: f32);
    /// `vkCmdSetDepthClipNegativeOneToOneEXT`.
    fn set_clip_negative_one_to_one(&mut self, negative_one_to_one: bool);
    /// `vkCmdSetDepthClampRangeEXT`: the viewport's range (`None`) or a user-defined one.
    fn set_clamp_range(&mut self, range: Option<(f32, f32)>);
    /// Binds a graphics pipeline (a compare-op variant, or the application's pipeline back).
    fn bind_pipeline(&mut self, pipeline: vk::Pipeline);
    /// Binds a shader object to `stage` (a variant revz made, or the application's shader
    /// back).
    fn bind_shader(&mut self, stage: vk::ShaderStageFlags, shader: vk::ShaderEXT);
}

/// Depth state of one command buffer while it records.
#[derive(Clone, Debug)]
pub struct CommandState {
    /// The pipelines this recording bound.
    known: KnownPipelines,
    /// The slot of the bound graphics pipeline in `known`; `None` when none is bound (or
    /// shader objects are). Its depth state is `None` when it is not tracked: then every state
    /// the application set is emitted as dynamic.
    bound: Option<usize>,
    target: Target,
    /// The target a secondary command buffer assumed at its begin.
    inherited: Target,
    /// The viewports the application set.
    viewports: AppViewports,
    compare_op: vk::CompareOp,
    bias: DepthBias,
    bounds: (f32, f32),
    /// The application's `vkCmdSetDepthClipNegativeOneToOneEXT` (with
    /// `States::CLIP_CONTROL` in `app_set`).
    clip_negative_one_to_one: bool,
    /// The clamp range the application set (`States::CLAMP_RANGE` in `app_set`): `None` the
    /// viewport's, else a user-defined one.
    clamp_range: Option<(f32, f32)>,
    /// `vkCmdSetDepthClampEnableEXT`'s value (false until the application sets it).
    depth_clamp: bool,
    /// `vkCmdSetDepthClipEnableEXT`'s value (`None` until the application sets it).
    depth_clip: Option<bool>,
    /// Which states the application set with `vkCmdSet*`.
    app_set: States,
    reversing: Reversing,
    /// Infinite mode: the n / f in `reversing` is a camera of this recording's draws (a
    /// projection it pushed, or the one the pass's image remembered), not just the device's
    /// last seen at its begin, which may be another camera's. Only such an n / f is
    /// remembered for an image ([`Self::camera`]).
    camera_known: bool,
    push: PushConstants,
    /// The path the emitted state is for.
    path: DrawPath,
    /// Draw commands recorded per path, and per depth image and pipeline, for the depth
    /// profile (`crate::profile`); executed secondaries' are added to their primary's.
    draws: DrawTally,
    /// The cameras executed secondaries classified matrices as (their best line, convention
    /// and count), for the depth profile: a secondary is never submitted itself.
    executed_matches: Vec<(revz_math::DepthLine, revz_math::DepthConvention, u32)>,
    emitted: Emitted,
    /// The variant revz bound in the bound pipeline's place (`None`: the application's).
    variant_bound: Option<vk::Pipeline>,
    /// The current subpass reads a reversed depth image through an input attachment: its
    /// pipelines' input variants apply ([`PipelineDepth::variant_for`]).
    reversed_inputs: bool,
    /// Infinite mode: the current depth image stores complementary depth (it is read as an
    /// input attachment, whose conversion in the reading shader cannot know n/f:
    /// `crate::policy::DevicePolicy::stores_complementary`). Its draws map as complementary
    /// mode does ([`CommandState::target_reversing`]).
    complementary_target: bool,
    /// The UNORM format the current depth attachment was created with, when revz promoted
    /// it to float: draws bind promoted variants, and constant depth bias is converted.
    promoted_from: Option<vk::Format>,
    /// What revz last pushed as its carrier, and with which layout: pushed again only when
    /// the value or the application's push layout changes.
    carrier_held: Option<(vk::PipelineLayout, [u32; 4])>,
    /// revz's layout with the push ranges of the application's last push layout
    /// ([`PipelineDepth::layout`] of its pipelines; null: unknown), to tell whether that
    /// layout is push-compatible with the bound pipeline.
    push_pusher: vk::PipelineLayout,
    /// The stages the application's pushes with its last push layout must name as well
    /// (`crate::precise::PushPatch`; [`crate::precise::PushPatch::NONE`] where that layout
    /// needs none: one compare per push, no branch on an option).
    push_patch: crate::precise::PushPatch,
    /// The application pushed since the last graphics bind: with a layout the bound pipeline
    /// is not compatible with, it pushes for the next pipeline, and revz's carrier must not
    /// go down over its bytes now (it goes with the next compatible push or bind).
    pushed_since_bind: bool,
    /// The shader object the application bound to the fragment stage (null: none), and what
    /// revz knows of it when it computes with depth.
    fragment_shader: (vk::ShaderEXT, Option<FragmentShader>),
    /// Whether revz bound the bound fragment shader object's reversed variant in its place.
    shader_variant_bound: bool,
    /// The shader objects the application bound to the vertex, tessellation evaluation,
    /// geometry and mesh stages ([`POSITION_STAGES`]; null: none), and what revz knows of them
    /// where they store `Position` (precise modes).
    position_shaders: [(vk::ShaderEXT, Option<PositionShader>); POSITION_STAGES.len()],
    /// The tessellation control shader object bound copies the positions on
    /// ([`PositionShader::PassesThrough`]): an evaluation shader that interpolates them then
    /// leaves the rewrite to the stage before ([`Self::last_position_stage`]).
    control_carries_positions: bool,
    /// The stage (index in [`POSITION_STAGES`]) whose application shader revz replaced by its
    /// baked variant, and that variant.
    position_variant_bound: Option<(usize, vk::ShaderEXT)>,
    /// Graphics shader objects were bound since the last pipeline bind: the fields above hold
    /// something a pipeline bind must forget.
    shader_objects: bool,
    /// A secondary that inherits its viewports from the primary that executes it
    /// (`VK_NV_inherited_viewport_scissor`): its draws take the flip path, the one the
    /// primary sends its viewports for ([`CommandState::flush_viewports_for_secondaries`]).
    inherits_viewports: bool,
    /// Draws cannot take the precise path whatever their projection: `inherits_viewports`, or
    /// [`CommandState::clamps_at_far`]. Kept up to date where either changes (a viewport
    /// inheritance, a bind, `vkCmdSetDepthClampEnableEXT`) so that the push and draw paths
    /// read one flag.
    precise_barred: bool,
    /// The current subpass (or rendering instance) records its draws in secondaries: no
    /// state command may be recorded in it.
    secondary_contents: bool,
    /// Draws can be recorded now: inside a render pass or rendering instance, or in a
    /// secondary that continues one. State is only sent down here ([`Self::settle`]).
    in_pass: bool,
    dirty: bool,
    /// States whose values a bind changed where the state stayed settled otherwise
    /// ([`PipelineDepth::values_apart`]): the next settle evaluates these alone.
    values_pending: States,
    /// What a push does to the settled state, where it changes nothing revz sends
    /// ([`push_shortcut`]); `None` where unknown.
    shortcut: Option<PushShortcut>,
    /// The last full push changed the carrier (a new camera): settles do not write the
    /// shortcut down until a push keeps it (a frame of a new camera per push would only pay
    /// for it).
    carrier_churn: bool,
}

impl Default for CommandState {
    fn default() -> Self {
        CommandState {
            known: KnownPipelines::default(),
            bound: None,
            target: Target::None,
            inherited: Target::None,
            viewports: AppViewports::default(),
            compare_op: vk::CompareOp::NEVER,
            bias: DepthBias::default(),
            bounds: (0.0, 1.0),
            clip_negative_one_to_one: false,
            clamp_range: None,
            depth_clamp: false,
            depth_clip: None,
            app_set: States::NONE,
            reversing: Reversing::default(),
            camera_known: false,
            push: PushConstants::default(),
            path: DrawPath::Native,
            draws: DrawTally::default(),
            executed_matches: Vec::new(),
            emitted: Emitted::default(),
            variant_bound: None,
            reversed_inputs: false,
            complementary_target: false,
            promoted_from: None,
            carrier_held: None,
            push_pusher: vk::PipelineLayout::null(),
            push_patch: crate::precise::PushPatch::NONE,
            pushed_since_bind: false,
            fragment_shader: (vk::ShaderEXT::null(), None),
            shader_variant_bound: false,
            position_shaders: std::array::from_fn(|_| (vk::ShaderEXT::null(), None)),
            control_carries_positions: false,
            position_variant_bound: None,
            shader_objects: false,
            inherits_viewports: false,
            precise_barred: false,
            secondary_contents: false,
            in_pass: false,
            dirty: true,
            values_pending: States::NONE,
            shortcut: None,
            carrier_churn: false,
        }
    }
}

impl CommandState {
    /// A command buffer of a device reversing as `reversing` says.
    pub fn new(reversing: Reversing) -> CommandState {
        CommandState {
            reversing,
            ..CommandState::default()
        }
    }

    /// Starts recording (`vkBeginCommandBuffer`): all state is undefined again. `reversal`
    /// is the device's current map (infinite mode learns n / f from the projections it sees),
    /// `cameras` the cameras the device has seen.
    /// A begin with a depth target (a secondary continuing a pass) is inside that pass; a
    /// secondary continuing a pass without depth says so with [`Self::set_target`].
    pub fn begin(&mut self, target: Target, reversal: Reversal, cameras: Cameras) {
        *self = CommandState {
            target,
            inherited: target,
            in_pass: target != Target::None,
            reversing: Reversing {
                reversal,
                ..self.reversing
            },
            push: PushConstants::with_cameras(cameras),
            ..CommandState::default()
        };
    }

    /// The cameras this recording meets that the device's table lacks are looked up in
    /// `first_seen`, which the device's other recordings share (`crate::precise::FirstSeen`).
    pub fn share_first_seen(&mut self, first_seen: std::sync::Arc<crate::precise::FirstSeen>) {
        self.push.share_first_seen(first_seen);
    }

    /// The cameras this recording found or improved, if it did (the device learns them at
    /// the recording's end, for the recordings begun after it).
    pub fn take_changed_cameras(&mut self) -> Option<Cameras> {
        self.push
            .take_changed()
            .then(|| self.push.cameras().clone())
    }

    /// The map of standard depth onto this command buffer's reversed attachments.
    pub fn reversal(&self) -> Reversal {
        self.reversing.reversal
    }

    /// How draws into the current target are reversed: the command buffer's
    /// ([`Self::reversal`]), or complementary mode's where the target stores complementary
    /// depth in infinite mode ([`Self::set_complementary_target`]). The camera it learned
    /// stays the command buffer's for its other targets.
    #[inline]
    fn target_reversing(&self) -> Reversing {
        if self.complementary_target {
            Reversing {
                rewrite: self.reversing.rewrite.map(|_| RewriteTarget::Complementary),
                reversal: Reversal::Complementary,
            }
        } else {
            self.reversing
        }
    }

    /// Infinite mode: whether the current depth image stores complementary depth
    /// ([`Self::set_complementary_target`]).
    pub fn complementary_target(&self) -> bool {
        self.complementary_target
    }

    /// Infinite mode: whether the current depth image stores complementary depth (render pass
    /// begin, next subpass, rendering begin, a secondary continuing a pass).
    pub fn set_complementary_target(&mut self, complementary: bool) {
        if self.complementary_target != complementary {
            self.complementary_target = complementary;
            self.bar_precise();
            self.dirty = true;
        }
    }

    /// Infinite mode: a pass begins into a reversed image whose draws' camera had this n / f
    /// (remembered when a pass into it last ended): its flip-path state follows that camera
    /// until a projection pushed in the pass tells another.
    pub fn enter_camera(&mut self, near_over_far: f32) {
        if let Reversal::Infinite { near_over_far: r } = &mut self.reversing.reversal {
            self.camera_known = true;
            if !same_near_over_far(*r, near_over_far) {
                *r = near_over_far;
                self.dirty = true;
            }
            self.drop_shortcut();
        }
    }

    /// Infinite mode: the n / f of this recording's draws now, where it is a camera they use
    /// (learned from a pushed projection, or entered from an image); `None` where it is only
    /// the device's last seen at the begin, or 0.
    pub fn camera(&self) -> Option<f32> {
        match self.reversing.reversal {
            Reversal::Infinite { near_over_far } if self.camera_known && near_over_far != 0.0 => {
                Some(near_over_far)
            }
            _ => None,
        }
    }

    /// The path the last draw took.
    pub fn path(&self) -> DrawPath {
        self.path
    }

    /// The draw commands recorded so far, per path.
    pub fn draws(&self) -> DrawCounts {
        self.draws.totals()
    }

    /// The draw commands recorded so far per depth image and pipeline (the depth profile).
    pub fn tally(&self) -> &DrawTally {
        &self.draws
    }

    /// The depth profile's keys: the depth image (raw handle, 0: none or not known) and the
    /// pipeline or vertex shader object (raw handle) the next draws are counted under. Set by
    /// the hooks only where the device keeps a profile.
    pub fn tally_image(&mut self, image: u64) {
        self.draws.set_image(image);
    }

    pub fn tally_pipeline(&mut self, pipeline: u64) {
        self.draws.set_pipeline(pipeline);
    }

    /// The cameras this recording classified matrices as, each with how many (the depth
    /// profile): the camera's best line, its convention and the count.
    pub fn camera_matches(
        &self,
    ) -> impl Iterator<Item = (revz_math::DepthLine, revz_math::DepthConvention, u32)> + '_ {
        let cameras = self.push.cameras();
        self.push
            .matches()
            .iter()
            .enumerate()
            .filter(|(_, &count)| count > 0)
            .filter_map(move |(index, &count)| {
                let (_, _, convention, line) = cameras.camera(index)?;
                Some((line, convention, count))
            })
            .chain(self.executed_matches.iter().copied())
    }

    /// `vkCmdExecuteCommands` of `secondary` (the depth profile): its draws and camera
    /// matches are this command buffer's.
    pub fn add_executed(&mut self, secondary: &CommandState) {
        self.draws.add_executed(&secondary.draws);
        let matches: Vec<_> = secondary.camera_matches().collect();
        self.executed_matches.extend(matches);
    }

    fn count_draw(&mut self) {
        use crate::profile::DrawnPath as Path;
        self.draws.count(match self.path {
            DrawPath::Native => Path::Native,
            DrawPath::Flip => Path::Flip,
            DrawPath::Precise => Path::Precise,
        });
    }

    /// Whether the next draw clamps depth without clipping it in infinite mode, whose precise
    /// path removes the far plane it would clamp at: such a draw takes the flip path. The
    /// clamp is the pipeline's static one or the application's dynamic value
    /// (`vkCmdSetDepthClampEnableEXT`), the clipping its static state, the dynamic value
    /// (`vkCmdSetDepthClipEnableEXT`), or the spec's default (clipped where not clamped). A
    /// static clamp without clipping sends the pipeline to the flip path at its creation
    /// already (`crate::policy::vertex_stage::depth_clamp_flip`); a clamp with clipping on
    /// (D3D translators') changes no depth the precise path stores.
    fn clamps_at_far(&self) -> bool {
        if self.target_reversing().rewrite != Some(RewriteTarget::Infinite) {
            return false;
        }
        // With shader objects (no pipeline) both are dynamic.
        let (clamp, clip) = match self.pipeline() {
            Some(p) if !p.app_dynamic.contains(States::DEPTH_CLAMP) => {
                (p.static_clamp, p.depth_clip)
            }
            Some(p) => (self.depth_clamp, p.depth_clip),
            None => (self.depth_clamp, DepthClip::Dynamic),
        };
        clamp && !clip.clips(clamp, self.depth_clip)
    }

    /// The projection the bound pipeline's draws would rewrite now, if any.
    #[inline]
    fn precise_use(&self) -> Option<(&ProjectionUse, RewriteTarget)> {
        if self.target != Target::Reversed || self.precise_barred {
            return None;
        }
        let projection = match self.bound {
            Some(slot) => self.known.slots[slot].1.as_ref()?.projection.as_ref()?,
            None => self.shader_projection()?,
        };
        Some((projection, self.target_reversing().rewrite?))
    }

    /// The mode whose depth the bound pipeline's vertex stage derives itself for the next
    /// draw, if it does (`crate::shader::derived_range`): a reversed attachment, viewports of its own,
    /// a rewriting mode, and a stage that derives its range.
    #[inline]
    fn derived_use(&self) -> Option<(RewriteTarget, DepthConvention)> {
        if self.target != Target::Reversed || self.precise_barred {
            return None;
        }
        let negative_one_to_one =
            self.app_set.contains(States::CLIP_CONTROL) && self.clip_negative_one_to_one;
        let convention = match self.stage_facts() {
            Some(pipeline) => {
                pipeline.derived_range?;
                // A dynamic [-1, 1] clip convention (Zink): the stage converts its fitted
                // line, and revz sets [0, 1] for the draw ([`Self::emit`]), where reversed
                // depth near 0 keeps float32's resolution.
                if pipeline.app_dynamic.contains(States::CLIP_CONTROL) && negative_one_to_one {
                    DepthConvention::NegativeOneToOne
                } else {
                    DepthConvention::ZeroToOne
                }
            }
            // Shader objects without a pushed route: a baked variant of the last
            // pre-rasterization stage, which stores [0, 1] depth (its selector cannot follow a
            // [-1, 1] convention).
            None => {
                self.baked_shader()?;
                if negative_one_to_one {
                    return None;
                }
                DepthConvention::ZeroToOne
            }
        };
        Some((self.target_reversing().derived_target()?, convention))
    }

    /// Whether the next draw's last pre-rasterization stage can be one with the carrier baked
    /// in (the bound pipeline's variants, or the bound shader objects'): such a stage stores
    /// complementary depth on the precise path, and nothing is pushed for it.
    fn draws_baked(&self) -> bool {
        match self.stage_facts() {
            Some(pipeline) => pipeline.baked,
            None => self.baked_shader().is_some(),
        }
    }

    /// With shader objects bound: the last pre-rasterization stage bound (index in
    /// [`POSITION_STAGES`]) that stores the positions rasterized: a geometry shader that
    /// passes them through ([`PositionShader::PassesThrough`]) leaves it the stage bound
    /// before it, and so does an evaluation shader that interpolates them after a control
    /// shader that copies them.
    fn last_position_stage(&self) -> Option<usize> {
        const EVALUATION: usize = 1;
        debug_assert_eq!(
            POSITION_STAGES[EVALUATION],
            vk::ShaderStageFlags::TESSELLATION_EVALUATION
        );
        let bound = |shaders: &[(vk::ShaderEXT, Option<PositionShader>)]| {
            shaders
                .iter()
                .rposition(|(shader, _)| *shader != vk::ShaderEXT::null())
        };
        let mut last = bound(&self.position_shaders)?;
        while self.position_shaders[last].1 == Some(PositionShader::PassesThrough)
            && (last != EVALUATION || self.control_carries_positions)
        {
            last = bound(&self.position_shaders[..last])?;
        }
        Some(last)
    }

    /// `vkCmdBindShadersEXT` naming the tessellation control stage: whether the shader it
    /// binds there (none: `false`) copies the positions on.
    pub fn bind_control_shader(&mut self, carries_positions: bool) {
        if self.control_carries_positions != carries_positions {
            self.control_carries_positions = carries_positions;
            self.dirty = true;
        }
    }

    /// With shader objects bound: the application's shader of the last pre-rasterization
    /// stage bound (the depth profile files the draws under it).
    pub fn last_position_shader(&self) -> Option<vk::ShaderEXT> {
        Some(self.position_shaders[self.last_position_stage()?].0)
    }

    /// With shader objects bound: the last pre-rasterization stage (index in
    /// [`POSITION_STAGES`]), the application's shader there and what revz knows of it, where
    /// precise-path draws may bind its variant: one that projects the previous stage's
    /// `Position` only where the shaders bound before it give w = 1
    /// ([`Self::input_unit_w`]; a pipeline checks this at its creation).
    fn rewritten_stage(&self) -> Option<(usize, vk::ShaderEXT, &PositionShader)> {
        if !self.shader_objects {
            return None;
        }
        let last = self.last_position_stage()?;
        let (shader, position) = &self.position_shaders[last];
        let position = position.as_ref()?;
        if position.projects_input() && !self.input_unit_w(last) {
            return None;
        }
        Some((last, *shader, position))
    }

    /// With shader objects bound: whether the positions the shader of stage `at` (index in
    /// [`POSITION_STAGES`]) reads from the stage before it have w = 1, as
    /// `hooks::pipeline::plan`'s `prior_stage_w_one` decides for a pipeline: a geometry
    /// shader's come from the evaluation shader bound (else the vertex shader), which stores
    /// `vec4(p, 1.0)` itself or, interpolating the patch's positions
    /// ([`PositionShader::PassesThrough`]), has a control shader that copies them from a
    /// vertex shader storing them so; an evaluation shader's come through the control shader,
    /// which must copy them from such a vertex shader.
    fn input_unit_w(&self, at: usize) -> bool {
        const VERTEX: usize = 0;
        const EVALUATION: usize = 1;
        const GEOMETRY: usize = 2;
        debug_assert_eq!(POSITION_STAGES[GEOMETRY], vk::ShaderStageFlags::GEOMETRY);
        let stores_unit_w = |stage: usize| {
            self.position_shaders[stage]
                .1
                .as_ref()
                .is_some_and(PositionShader::stores_unit_w)
        };
        let interpolated_unit_w = || self.control_carries_positions && stores_unit_w(VERTEX);
        let evaluation_bound = self.position_shaders[EVALUATION].0 != vk::ShaderEXT::null();
        match at {
            GEOMETRY if evaluation_bound => {
                stores_unit_w(EVALUATION)
                    || (self.position_shaders[EVALUATION].1 == Some(PositionShader::PassesThrough)
                        && interpolated_unit_w())
            }
            GEOMETRY => stores_unit_w(VERTEX),
            EVALUATION => interpolated_unit_w(),
            _ => false,
        }
    }

    /// With shader objects bound: the last pre-rasterization stage's (index in
    /// [`POSITION_STAGES`]), the application's shader there, and its variant with the
    /// carrier baked in, where it has one.
    fn baked_shader(&self) -> Option<(usize, vk::ShaderEXT, vk::ShaderEXT)> {
        match self.rewritten_stage()? {
            (last, shader, PositionShader::Baked { variant, .. }) => Some((last, shader, *variant)),
            _ => None,
        }
    }

    /// With shader objects bound: the last pre-rasterization stage (index in
    /// [`POSITION_STAGES`]) and revz's variant of its shader, baked or reading the pushed
    /// carrier, where it has one: what precise-path draws bind there.
    fn position_variant(&self) -> Option<(usize, vk::ShaderEXT)> {
        let (last, _, position) = self.rewritten_stage()?;
        Some((last, position.variant()?))
    }

    /// What the precise path reads of the last pre-rasterization stage (its projection, the
    /// carrier, a derived range, the layout revz pushes with): the bound pipeline's facts, or
    /// with shader objects bound, those of the last stage's shader where it takes the pushed
    /// route ([`PositionShader::Pushed`]; `None` for a baked or flip shader, whose route
    /// [`Self::baked_shader`] gives).
    /// A pipeline bound costs nothing more than [`Self::pipeline`]: with shader objects bound
    /// no pipeline is (`bound` is `None`), and only then are the shaders looked at.
    #[inline]
    fn stage_facts(&self) -> Option<&std::sync::Arc<PipelineDepth>> {
        match self.bound {
            Some(slot) => self.known.slots[slot].1.as_ref(),
            None => self.shader_facts(),
        }
    }

    /// [`Self::stage_facts`] with shader objects bound (cold: most recordings bind pipelines).
    #[cold]
    #[inline(never)]
    fn shader_facts(&self) -> Option<&std::sync::Arc<PipelineDepth>> {
        match self.rewritten_stage()? {
            (_, _, PositionShader::Pushed { depth, .. }) => Some(depth),
            _ => None,
        }
    }

    /// The projection of the pushed route's vertex shader object bound last, where the draw
    /// can classify it: it was classified for [0, 1] clip depth, so a draw the application set
    /// to [-1, 1] (`vkCmdSetDepthClipNegativeOneToOneEXT`) takes the flip path. (A pipeline's
    /// is classified for its static convention; one whose convention is dynamic has none.)
    #[cold]
    #[inline(never)]
    fn shader_projection(&self) -> Option<&ProjectionUse> {
        if self.clip_negative_one_to_one && self.app_set.contains(States::CLIP_CONTROL) {
            return None;
        }
        self.shader_facts()?.projection.as_ref()
    }

    /// The application's next push uses a layout whose push ranges revz's layout `pusher`
    /// has (null: unknown); called before [`Self::push_constants`] when the layout changes.
    pub fn note_push_pusher(
        &mut self,
        pusher: vk::PipelineLayout,
        patch: Option<crate::precise::PushPatch>,
    ) {
        self.push_pusher = pusher;
        self.push_patch = patch.unwrap_or(crate::precise::PushPatch::NONE);
        self.drop_shortcut();
    }

    /// The stages an application's push of `size` bytes at `offset` with `stages`, with the
    /// layout last noted ([`Self::note_push_pusher`]), goes down with.
    #[inline]
    pub fn push_stages(
        &self,
        offset: u32,
        size: u32,
        stages: vk::ShaderStageFlags,
    ) -> vk::ShaderStageFlags {
        self.push_patch.stages_of(offset, size, stages)
    }

    /// The application's last push layout, null before its first push.
    pub fn push_layout(&self) -> vk::PipelineLayout {
        self.push.layout()
    }

    /// Whether the application's last push layout is push-compatible with the bound
    /// pipeline's (unknown counts as compatible: pipelines without revz's layout).
    fn push_compatible(&self) -> bool {
        let own = self
            .stage_facts()
            .map_or(vk::PipelineLayout::null(), |p| p.layout);
        own == vk::PipelineLayout::null() || self.push_pusher == own
    }

    /// `vkCmdPushConstants` of `data` with `stages` at `offset`: classifies the bound
    /// pipeline's projection when the push reaches it. Returns the outcome of a classification,
    /// if one was made (the caller reports already reversed projections), and the push to send
    /// in the application's place when the carrier changes with it ([`FoldedPush`]: the
    /// application's bytes extended to the carrier's); otherwise the application's push goes
    /// down unchanged.
    pub fn push_constants(
        &mut self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        data: &[u8],
    ) -> (Option<Outcome>, Option<FoldedPush>) {
        if layout != self.push.layout() {
            // Values pushed with another layout may have disturbed the carrier.
            self.carrier_held = None;
            self.dirty = true;
        }
        self.push.push(layout, offset, data);
        self.pushed_since_bind = true;
        // The bound pipeline's projection, where this push writes some of its bytes.
        let end = u64::from(offset) + data.len() as u64;
        let written = self
            .precise_use()
            .map(|(use_, target)| (*use_, target))
            .filter(|(use_, _)| {
                u64::from(offset) < u64::from(use_.end()) && u64::from(use_.offset) < end
            });
        let Some((use_, target)) = written else {
            let folded = self.fold(layout, stages, offset, None);
            self.refresh_shortcut(None);
            return (None, folded);
        };
        if self.carrier_churn {
            // The last push brought a new camera: this one likely does too (a projection per
            // draw), which the same-camera test would only decline.
            self.push.search_next();
        }
        let outcome = self.push.outcome(&use_, target);
        match outcome {
            Some(outcome) => {
                self.learn(&outcome);
                if self.pushed_path(&outcome) != self.path {
                    self.dirty = true;
                }
            }
            None => self.dirty = true,
        }
        let folded = self.fold(layout, stages, offset, outcome);
        // Where the carrier changed with this push (a new camera), the next push is likely
        // another (a projection per draw), and the shortcut would only cost: the same
        // camera's next push writes it down (on this path, without a search).
        self.carrier_churn = folded.is_some();
        self.refresh_shortcut(outcome);
        (outcome, folded)
    }

    /// The path a settle gives the next draw where the bound pipeline's projection (of a
    /// reversed target) classifies as `outcome` and the carrier goes down: precise for a
    /// camera's projection, and for any matrix a stage that also fits its range gets (its
    /// fit: issue #41, a later stage's push-constant projection); flip otherwise. What a push
    /// and the push shortcut compare with the path held: the settle's rule
    /// ([`Self::settle`]), or every other such push would mark the state dirty.
    #[inline]
    pub(super) fn pushed_path(&self, outcome: &Outcome) -> DrawPath {
        match outcome {
            Outcome::Rewritten { .. } => DrawPath::Precise,
            _ if self.derived_use().is_some() => DrawPath::Precise,
            _ => DrawPath::Flip,
        }
    }

    /// The bytes of a push [`Self::push_constants`] just returned, written into `out`.
    pub fn folded_bytes<'a>(
        &self,
        folded: &FoldedPush,
        out: &'a mut [std::mem::MaybeUninit<u8>; crate::precise::PUSH_CONSTANT_BYTES],
    ) -> &'a [u8] {
        self.push.folded_bytes(folded, out)
    }

    /// The push returned by [`Self::push_constants`] was not sent extended: the next draw
    /// sends the carrier.
    pub fn unfold(&mut self) {
        self.carrier_held = None;
        self.dirty = true;
    }

    /// The application's push extended to the carrier, where the bound pipeline reads it and
    /// its value for the next draw (`outcome` of this push) is not the one held.
    fn fold(
        &mut self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        outcome: Option<Outcome>,
    ) -> Option<FoldedPush> {
        let carrier = self.stage_facts()?.position_store?;
        if !self.push_compatible() {
            // A push for another pipeline: the carrier goes with a later push or bind.
            return None;
        }
        if self.target == Target::Reversed && outcome.is_none() && self.precise_use().is_some() {
            // Another classification for the draw decides (at the draw).
            return None;
        }
        let values = self.carrier_values(outcome);
        let held = (layout, values.map(f32::to_bits));
        if self.carrier_held == Some(held) {
            return None;
        }
        let folded = self.push.fold_carrier(&carrier, stages, offset, &values);
        match folded {
            Some(_) => self.carrier_held = Some(held),
            // The draw pushes it.
            None => self.dirty = true,
        }
        folded
    }

    /// What the carrier must hold for the next draw, given the outcome of its projection: the
    /// camera's reversed depth line on the precise path, the shader's own z everywhere else.
    #[inline]
    fn carrier_values(&self, outcome: Option<Outcome>) -> [f32; 4] {
        // A projection the CPU classified as a camera's: its line (selector 0, which a stage
        // that also derives its range keeps: issue #41, a later stage's push-constant matrix).
        if let (Target::Reversed, Some(Outcome::Rewritten { carrier, .. })) = (self.target, outcome)
        {
            return carrier;
        }
        if let Some((target, convention)) = self.derived_use() {
            return derived_selector(target, convention);
        }
        FLIP_CARRIER
    }

    /// Infinite mode: a rewritten projection tells n / f, which flip-path state follows.
    fn learn(&mut self, outcome: &Outcome) {
        if let (Outcome::Rewritten { near_over_far, .. }, Reversal::Infinite { near_over_far: r }) =
            (outcome, &mut self.reversing.reversal)
        {
            self.camera_known = true;
            if !same_near_over_far(*r, *near_over_far) {
                *r = *near_over_far;
                // Only flip-path viewports and depth bounds depend on it (and what a stage that
                // derives its range stores, [`Reversing::derived_target`]; such a pipeline
                // has no pushed projection to learn from, so its bind settles again).
                let bounds = self
                    .stage_facts()
                    .is_some_and(|p| (p.app_dynamic | p.injected).contains(States::BOUNDS));
                if self.path != DrawPath::Precise || bounds {
                    self.dirty = true;
                }
            }
        }
    }

    pub fn target(&self) -> Target {
        self.target
    }

    /// The target this command buffer was begun with (what a secondary assumed).
    pub fn inherited(&self) -> Target {
        self.inherited
    }

    /// The UNORM format the current attachment was promoted from (see [`Self::set_promoted`]).
    pub fn promoted_from(&self) -> Option<vk::Format> {
        self.promoted_from
    }

    /// Whether draws go to a promoted attachment (a promoted twin's subpass, or a rendering
    /// instance with a promoted view).
    pub fn promoted(&self) -> bool {
        self.promoted_from.is_some()
    }

    /// The current depth attachment's image was promoted from `format` (`None`: it keeps
    /// its format, or there is none).
    pub fn set_promoted(&mut self, promoted_from: Option<vk::Format>) {
        if self.promoted_from != promoted_from {
            self.promoted_from = promoted_from;
            self.dirty = true;
        }
    }

    /// Draws go to `target` now (render pass begin, next subpass, rendering begin, a
    /// secondary continuing a pass).
    pub fn set_target(&mut self, target: Target) {
        self.in_pass = true;
        if self.target != target {
            self.target = target;
            self.dirty = true;
        }
    }

    /// Whether the current subpass reads a reversed depth image through an input attachment
    /// (render pass begin, next subpass, a secondary continuing a pass).
    pub fn set_reversed_inputs(&mut self, reversed_inputs: bool) {
        if self.reversed_inputs != reversed_inputs {
            self.reversed_inputs = reversed_inputs;
            self.dirty = true;
        }
    }

    /// Whether a render pass or rendering instance is open (no transfer or dispatch can be
    /// recorded).
    pub fn in_pass(&self) -> bool {
        self.in_pass
    }

    /// The render pass or rendering instance ended: no draw can be recorded until the next,
    /// and nothing is sent down before it ([`Self::settle`]).
    pub fn leave_pass(&mut self) {
        self.in_pass = false;
        self.reversed_inputs = false;
        self.set_complementary_target(false);
        if self.target != Target::None {
            self.target = Target::None;
            self.dirty = true;
        }
    }

    /// `vkCmdBindPipeline` of `app`, after [`Self::bind_pipeline`]: the pipeline to send down
    /// in its place, so that a reversed variant is bound at once instead of the application's
    /// pipeline and then the variant.
    pub fn pipeline_to_bind(&mut self, app: vk::Pipeline) -> vk::Pipeline {
        let Some(pipeline) = self.pipeline().filter(|_| self.in_pass) else {
            return app;
        };
        // A pipeline with the carrier baked into its reversed variants: those where its draws
        // will take the precise path ([`Self::settle`]).
        let reversed =
            self.target == Target::Reversed && (!pipeline.baked || self.derived_use().is_some());
        let wanted = pipeline.variant_for(reversed, self.promoted(), self.reversed_inputs);
        self.variant_bound = wanted;
        wanted.unwrap_or(app)
    }

    /// `vkCmdBindShadersEXT`, after [`Self::bind_shaders`]: the stage (index in
    /// [`POSITION_STAGES`]) and baked variant to send down in place of the application's
    /// shader of the last pre-rasterization stage, where the next draw will take the precise
    /// path ([`Self::settle`]), as [`Self::pipeline_to_bind`] does for pipelines. The caller
    /// says whether it sent it ([`Self::position_variant_sent`]).
    pub fn position_shader_to_bind(&self) -> Option<(usize, vk::ShaderEXT)> {
        if !self.in_pass {
            return None;
        }
        let (stage, variant) = self.position_variant()?;
        // A baked variant where its stage derives the draw's depth; one reading the pushed
        // carrier where the draw will likely classify its projection as a camera's (the
        // settle binds the application's shader back where it does not).
        if self.derived_use().is_none() && self.precise_use().is_none() {
            return None;
        }
        // revz's variant of another stage is bound (a mesh shader bound after a vertex
        // shader's variant went down): the settle puts the application's shader back there
        // before it binds this one ([`Self::emit`]); substituting here would leave it
        // (found in review).
        if self
            .position_variant_bound
            .is_some_and(|(bound, _)| bound != stage)
        {
            return None;
        }
        Some((stage, variant))
    }

    /// The application's `vkCmdBindShadersEXT` went down with `variant` in its shader's place
    /// at `stage` ([`Self::position_shader_to_bind`]).
    pub fn position_variant_sent(&mut self, stage: usize, variant: vk::ShaderEXT) {
        self.position_variant_bound = Some((stage, variant));
    }

    /// `vkCmdBindPipeline` with a graphics pipeline: it unbinds the shader objects bound to
    /// graphics stages (revz's fragment variant with them).
    pub fn bind_pipeline(&mut self, pipeline: Option<std::sync::Arc<PipelineDepth>>) {
        let handle = pipeline.as_ref().map_or(vk::Pipeline::null(), |p| p.handle);
        let settled = self.settled_bind();
        let slot = self.known.insert(handle, pipeline);
        self.bind_slot(Some(slot), settled);
    }

    /// [`Self::bind_pipeline`] of the application's pipeline `handle`, whose depth state
    /// `lookup` finds where this recording has not bound it before (under the device's
    /// pipeline `generation`).
    #[inline]
    pub fn bind_pipeline_handle(
        &mut self,
        handle: vk::Pipeline,
        generation: u64,
        lookup: impl FnOnce() -> Option<std::sync::Arc<PipelineDepth>>,
    ) {
        let settled = self.settled_bind();
        let slot = self.known.slot(handle, generation, lookup);
        self.bind_slot(Some(slot), settled);
    }

    /// Before a pipeline bind: the slot and handle of the bound pipeline, where everything
    /// the last settle sent still holds for it (nothing changed since, in a pass where state
    /// goes down, and no push waits for a compatible pipeline: a bind ends that wait).
    fn settled_bind(&self) -> Option<(usize, vk::Pipeline)> {
        let slot = self.bound?;
        let settled = !self.dirty
            && self.in_pass
            && !self.secondary_contents
            && (!self.pushed_since_bind || self.push_compatible());
        settled.then(|| (slot, self.known.slots[slot].0))
    }

    /// Binds `slot`; `settled` is what [`Self::settled_bind`] said before it was looked up.
    /// Where the newly bound pipeline settles like the one it replaces but for the static
    /// values of states revz made dynamic ([`PipelineDepth::values_apart`]), the state stays
    /// settled and the next settle evaluates those states alone: a bind between pipelines that
    /// differ only in what revz does not touch, or in what a variant carries, goes down alone
    /// and its hook takes no second look; one between a LESS and a LESS_OR_EQUAL pipeline
    /// sends the flipped compare op and nothing else.
    fn bind_slot(&mut self, slot: Option<usize>, settled: Option<(usize, vk::Pipeline)>) {
        let apart = match (slot, settled) {
            // The previous pipeline's slot still holds it (the lookup may have reused it).
            // An untracked pipeline may set anything statically: what the application set
            // goes down again after it.
            (Some(slot), Some((previous, handle))) if self.known.slots[previous].0 == handle => {
                self.known.values_apart(previous, slot)
            }
            _ => None,
        };
        match apart {
            Some(apart) => {
                // The state stays settled: what bars the precise path is the same for both
                // pipelines (the application makes the same states dynamic), and the push
                // shortcut stays as it was: what it read of the pipeline (its projection,
                // carrier and layout) is the previous one's. What was sent of the states the
                // pipeline sets statically is still forgotten: something may have sent them
                // since the previous bind (the viewports flushed for secondaries; found in
                // review).
                self.take_static_state(slot);
                self.values_pending |= apart;
            }
            None => self.bind_graphics(slot),
        }
        // The pipeline replaces the shader objects bound to graphics stages (checked first:
        // a bind is a hot path, and most recordings bind no shader object).
        if self.shader_objects {
            self.shader_objects = false;
            self.fragment_shader = (vk::ShaderEXT::null(), None);
            self.shader_variant_bound = false;
            self.position_shaders = std::array::from_fn(|_| (vk::ShaderEXT::null(), None));
            self.control_carries_positions = false;
            self.position_variant_bound = None;
        }
    }

    /// The bound graphics pipeline's depth state, if it is tracked.
    #[inline]
    fn pipeline(&self) -> Option<&std::sync::Arc<PipelineDepth>> {
        self.bound
            .and_then(|slot| self.known.slots[slot].1.as_ref())
    }

    /// `vkCmdBindShadersEXT`: the bound pipeline is replaced. `fragment` is the shader object
    /// the call binds to the fragment stage (null: it unbinds the stage) and what revz knows of
    /// it, when the call names that stage; the fragment stage is left as it is otherwise (a
    /// variant revz bound stays in place of the application's shader). The same for the
    /// stages of [`POSITION_STAGES`] (`position`, each where the call names it).
    pub fn bind_shaders(
        &mut self,
        fragment: Option<(vk::ShaderEXT, Option<FragmentShader>)>,
        position: [Option<(vk::ShaderEXT, Option<PositionShader>)>; POSITION_STAGES.len()],
    ) {
        self.bind_graphics(None);
        self.shader_objects = true;
        if let Some(fragment) = fragment {
            // The application's bind goes down after this: its shader is the one bound now.
            self.fragment_shader = fragment;
            self.shader_variant_bound = false;
        }
        for (stage, bound) in position.into_iter().enumerate() {
            if let Some(bound) = bound {
                self.position_shaders[stage] = bound;
                if self
                    .position_variant_bound
                    .is_some_and(|(at, _)| at == stage)
                {
                    // The application's bind replaces revz's variant there.
                    self.position_variant_bound = None;
                }
            }
        }
    }

    /// A pipeline (`None`: untracked, or shader objects) becomes the source of static state.
    fn bind_graphics(&mut self, slot: Option<usize>) {
        self.take_static_state(slot);
        self.dirty = true;
        self.bar_precise();
    }

    /// The pipeline in `slot` is bound: what was sent of the states it sets statically is
    /// overwritten (an untracked pipeline, or shader objects, may set anything statically),
    /// no variant is bound yet, and the application has pushed nothing since.
    fn take_static_state(&mut self, slot: Option<usize>) {
        self.bound = slot;
        let dynamic = self
            .pipeline()
            .map_or(States::NONE, |p| p.app_dynamic | p.injected);
        self.emitted.forget_static(dynamic);
        self.variant_bound = None;
        self.pushed_since_bind = false;
    }

    /// Recomputes [`Self::precise_barred`](CommandState) after what it depends on changed.
    fn bar_precise(&mut self) {
        self.precise_barred = self.inherits_viewports || self.clamps_at_far();
    }

    /// A secondary begun with `VkCommandBufferInheritanceViewportScissorInfoNV`
    /// (`viewportScissor2D`): its viewports come from the primary, which sends them for the
    /// flip path, so its draws take the flip path too.
    pub fn inherit_viewports(&mut self) {
        self.inherits_viewports = true;
        self.bar_precise();
        self.dirty = true;
    }

    /// Whether the current subpass or rendering instance records its draws in secondaries.
    pub fn set_secondary_contents(&mut self, secondary: bool) {
        self.secondary_contents = secondary;
    }

    /// Whether state commands may be recorded here (not inside a subpass or rendering
    /// instance whose contents are secondaries).
    pub fn records_inline(&self) -> bool {
        !self.secondary_contents
    }

    /// Before secondaries can run (`vkCmdExecuteCommands`, or the begin of a subpass or
    /// rendering instance whose contents are secondaries, called before it is recorded): the
    /// viewports the application set here go down now, for the flip path, since the spec lets
    /// secondaries inherit them (`VK_NV_inherited_viewport_scissor`) and no draw of this
    /// command buffer may send them first. Only viewports: nothing else is inherited.
    pub fn flush_viewports_for_secondaries(&mut self, sink: &mut impl StateSink) {
        if !self
            .app_set
            .intersects(States::VIEWPORT | States::VIEWPORT_WITH_COUNT)
        {
            return;
        }
        let path = if self.target == Target::Reversed {
            DrawPath::Flip
        } else {
            DrawPath::Native
        };
        let reversal = self.target_reversing().reversal;
        let sink = &mut Filtered {
            sink,
            last: &mut self.emitted,
        };
        self.viewports
            .emit(sink, path, reversal, self.app_set, None);
        // The next draw of this command buffer decides its own path again.
        self.dirty = true;
    }

    /// `vkCmdExecuteCommands`: the secondaries leave the state undefined.
    pub fn invalidate(&mut self) {
        self.push.invalidate();
        self.carrier_held = None;
        self.emitted = Emitted::default();
        self.variant_bound = None;
        self.shader_variant_bound = false;
        self.position_variant_bound = None;
        self.dirty = true;
    }

    /// A push revz cannot follow (`vkCmdPushConstants2` with its layout in `pNext`): the
    /// push constants and revz's carrier in them are unknown; the bound pipeline (revz's
    /// variant, if it bound one) and the other state stay as they are.
    pub fn forget_push_constants(&mut self) {
        self.push.invalidate();
        self.carrier_held = None;
        self.dirty = true;
    }

    /// The depth bias was sent down outside the state machine (`vkCmdSetDepthBias2EXT` with
    /// a representation): the next emission must not assume it knows the value.
    pub fn forget_emitted_bias(&mut self) {
        self.emitted.bias = None;
    }

    /// `vkCmdSetViewport`. Viewports beyond [`MAX_VIEWPORTS`] are ignored.
    pub fn set_viewports(&mut self, first: u32, viewports: &[vk::Viewport]) {
        for (index, viewport) in (first as usize..).zip(viewports) {
            if index < MAX_VIEWPORTS {
                self.viewports.values[index] = *viewport;
                self.viewports.set |= 1 << index;
            }
        }
        self.app_set |= States::VIEWPORT;
        self.dirty = true;
    }

    /// `vkCmdSetViewportWithCount`.
    pub fn set_viewports_with_count(&mut self, viewports: &[vk::Viewport]) {
        let count = viewports.len().min(MAX_VIEWPORTS);
        self.viewports.values[..count].copy_from_slice(&viewports[..count]);
        self.viewports.count = Some(count as u32);
        self.app_set |= States::VIEWPORT_WITH_COUNT;
        self.dirty = true;
    }

    pub fn set_compare_op(&mut self, op: vk::CompareOp) {
        self.compare_op = op;
        self.app_set |= States::COMPARE_OP;
        self.dirty = true;
    }

    pub fn set_bias(&mut self, bias: DepthBias) {
        self.bias = bias;
        self.app_set |= States::BIAS;
        self.dirty = true;
    }

    /// `vkCmdSetDepthClampRangeEXT`: the viewport's range (`None`) or a user-defined one,
    /// sent at draws mapped like the depth bounds where the draw stores reversed depth.
    pub fn set_clamp_range(&mut self, range: Option<(f32, f32)>) {
        self.clamp_range = range;
        self.app_set |= States::CLAMP_RANGE;
        self.dirty = true;
    }

    /// `vkCmdSetDepthClipNegativeOneToOneEXT`.
    pub fn set_clip_negative_one_to_one(&mut self, negative_one_to_one: bool) {
        self.clip_negative_one_to_one = negative_one_to_one;
        self.app_set |= States::CLIP_CONTROL;
        self.dirty = true;
    }

    /// `vkCmdSetDepthClampEnableEXT` (followed in infinite mode only, where it can change a
    /// draw's path).
    pub fn set_depth_clamp(&mut self, enable: bool) {
        self.depth_clamp = enable;
        self.bar_precise();
        self.dirty = true;
    }

    /// `vkCmdSetDepthClipEnableEXT` (followed in infinite mode only: whether a clamping draw
    /// clips, and so keeps the precise path).
    pub fn set_depth_clip(&mut self, enable: bool) {
        self.depth_clip = Some(enable);
        self.bar_precise();
        self.dirty = true;
    }

    pub fn set_bounds(&mut self, min: f32, max: f32) {
        self.bounds = (min, max);
        self.app_set |= States::BOUNDS;
        self.dirty = true;
    }

    /// A draw (hooked only with the depth profile, which counts it): sends what
    /// [`Self::settle`] would, which is nothing when every hook settled.
    #[inline]
    pub fn before_draw(&mut self, sink: &mut impl StateSink) -> Option<Outcome> {
        let outcome = self.settle(sink);
        self.count_draw();
        outcome
    }

    /// [`Self::bind_pipeline`] whose next settle is a full one whatever the pipeline bound
    /// before (tests compare it with the shorter ones).
    #[cfg(test)]
    pub(crate) fn bind_pipeline_unsettled(
        &mut self,
        pipeline: Option<std::sync::Arc<PipelineDepth>>,
    ) {
        let handle = pipeline.as_ref().map_or(vk::Pipeline::null(), |p| p.handle);
        let slot = self.known.insert(handle, pipeline);
        self.bind_slot(Some(slot), None);
    }

    /// Whether [`Self::settle`] would send anything: state changed since the last settle, in a
    /// pass where draws are recorded inline.
    #[inline]
    pub fn wants_settle(&self) -> bool {
        (self.dirty || !self.values_pending.is_empty()) && self.in_pass && !self.secondary_contents
    }

    /// After a command that may change what the next draw needs (a bind, a push, a state
    /// setter, a pass begin, `vkCmdExecuteCommands`): sends down the depth state for the
    /// current target if it changed, so that draws need nothing from revz and go straight to
    /// the driver. Outside a pass (no draw can follow before a begin, which settles again) and
    /// inside a subpass of secondaries (nothing may be recorded there) it waits. Returns the
    /// outcome of a classification made for it, if any.
    #[inline]
    pub fn settle(&mut self, sink: &mut impl StateSink) -> Option<Outcome> {
        if !self.wants_settle() {
            return None;
        }
        if !self.dirty {
            // Only values a bind changed (`bind_slot`): nothing else a settle reads did.
            let pending = std::mem::replace(&mut self.values_pending, States::NONE);
            self.emit_values(sink, pending);
            return None;
        }
        self.values_pending = States::NONE;
        let outcome = match self.precise_use().map(|(p, t)| (*p, t)) {
            Some((use_, target)) => self.push.outcome(&use_, target),
            None => None,
        };
        if let Some(outcome) = &outcome {
            self.learn(outcome);
        }
        // The pipeline's rewritten vertex stage reads the carrier in every draw, into native
        // attachments too: it goes down (when it changed) with the application's push layout,
        // which the bound pipeline's is compatible with. Before the application's first push
        // there is none, and its own push constants are undefined as well.
        // A stage that derives its range: revz's own layout with the pipeline's push ranges
        // (`own`: the application may push nothing for it, or last pushed with another
        // pipeline's layout). Before the application's first push, the same.
        let (store, own, derived) = match self.stage_facts() {
            Some(p) => (p.position_store, p.layout, p.derived_range.is_some()),
            None => (None, vk::PipelineLayout::null(), false),
        };
        // Since the bind, the application pushed with a layout this pipeline is not
        // compatible with: it pushes for the next pipeline, and the carrier would overwrite
        // its bytes. It waits for the next compatible push or bind (the pipeline's draws take
        // the flip path meanwhile).
        let waits = self.pushed_since_bind && !self.push_compatible();
        let layout = match self.push.layout() {
            _ if waits => vk::PipelineLayout::null(),
            _ if derived && own != vk::PipelineLayout::null() => own,
            layout if layout != vk::PipelineLayout::null() && self.push_compatible() => layout,
            _ => own,
        };
        let carrier_ready = match store {
            Some(carrier) if layout != vk::PipelineLayout::null() => {
                let values = self.carrier_values(outcome);
                let held = (layout, values.map(f32::to_bits));
                if self.carrier_held != Some(held) {
                    sink.push_constants(
                        held.0,
                        carrier.stages,
                        carrier.offset,
                        &Carrier::bytes(&values),
                    );
                    self.carrier_held = Some(held);
                }
                true
            }
            _ => false,
        };
        self.path = match (self.target, outcome) {
            // The carrier pushed, or baked into the reversed variants bound for it.
            (Target::Reversed, _)
                if (carrier_ready || self.draws_baked()) && self.derived_use().is_some() =>
            {
                DrawPath::Precise
            }
            (Target::Reversed, Some(Outcome::Rewritten { .. })) if carrier_ready => {
                DrawPath::Precise
            }
            (Target::Reversed, _) => DrawPath::Flip,
            _ => DrawPath::Native,
        };
        self.emit(sink);
        self.dirty = false;
        self.refresh_shortcut(outcome);
        outcome
    }

    fn emit(&mut self, sink: &mut impl StateSink) {
        // Only what changed since it was last sent goes down. The bound pipeline, borrowed
        // apart from the fields written below.
        let reversal = self.target_reversing().reversal;
        let reversed = self.target == Target::Reversed;
        // With shader objects: the last pre-rasterization stage's baked variant, for a
        // precise-path draw (the flip path needs the application's shader).
        let position_wanted = if reversed && self.path == DrawPath::Precise {
            self.position_variant()
        } else {
            None
        };
        let bound = self
            .bound
            .and_then(|slot| self.known.slots[slot].1.as_ref());
        let filtered = &mut Filtered {
            sink: &mut *sink,
            last: &mut self.emitted,
        };
        if reversed && bound.is_some_and(|p| p.unreversed_fragment) {
            static WARNED: crate::logging::LogOnce = crate::logging::LogOnce::new();
            WARNED.log(|| {
                log::warn!(
                    "a pipeline whose fragment shader computes with depth (FragDepth or \
                     FragCoord.z) and could not be rewritten draws into a reversed depth \
                     attachment: its fragments keep standard depth"
                )
            });
        }
        if let Some(p) = bound {
            // A pipeline whose reversed variants have the carrier baked in: those only for
            // precise-path draws (the flip path needs the application's stage).
            let reversed_variant = reversed && (!p.baked || self.path == DrawPath::Precise);
            let wanted = p.variant_for(
                reversed_variant,
                self.promoted_from.is_some(),
                self.reversed_inputs,
            );
            if wanted != self.variant_bound {
                filtered.bind_pipeline(wanted.unwrap_or(p.handle));
                self.variant_bound = wanted;
            }
        }
        match self.fragment_shader {
            (shader, Some(FragmentShader::Reversed(variant)))
                if reversed != self.shader_variant_bound =>
            {
                filtered.bind_shader(
                    vk::ShaderStageFlags::FRAGMENT,
                    if reversed { variant } else { shader },
                );
                self.shader_variant_bound = reversed;
            }
            (_, Some(FragmentShader::Unreversed)) if reversed => {
                static WARNED: crate::logging::LogOnce = crate::logging::LogOnce::new();
                WARNED.log(|| {
                    log::warn!(
                        "a fragment shader object that computes with depth (FragDepth or \
                         FragCoord.z) and has no reversed variant (the rewrite refused it, its \
                         variant failed, it is linked, or its code is binary) draws into a \
                         reversed depth attachment: its fragments keep standard depth"
                    )
                });
            }
            _ => {}
        }
        if position_wanted != self.position_variant_bound {
            // The application's shader back where revz's variant of another stage was bound
            // (or none is wanted), then the variant wanted.
            if let Some((stage, _)) = self.position_variant_bound {
                if position_wanted.map(|(wanted, _)| wanted) != Some(stage) {
                    filtered.bind_shader(POSITION_STAGES[stage], self.position_shaders[stage].0);
                }
            }
            if let Some((stage, variant)) = position_wanted {
                filtered.bind_shader(POSITION_STAGES[stage], variant);
            }
            self.position_variant_bound = position_wanted;
        }
        let (from_app, pipeline) = match bound {
            Some(p) => (self.app_set & p.app_dynamic, Some(&**p)),
            None => (self.app_set, None),
        };
        self.viewports
            .emit(filtered, self.path, reversal, from_app, pipeline);
        self.emit_values(sink, States::ALL);
    }

    /// The depth states whose values come from the application or the bound pipeline
    /// (compare op, bias, clip convention, bounds, clamp range), those of `only`: each goes down
    /// where its value changed since it was last sent.
    fn emit_values(&mut self, sink: &mut impl StateSink, only: States) {
        let bound = self
            .bound
            .and_then(|slot| self.known.slots[slot].1.as_ref());
        let (from_app, injected, pipeline) = match bound {
            Some(p) => (self.app_set & p.app_dynamic, p.injected, Some(&**p)),
            None => (self.app_set, States::NONE, None),
        };
        let (from_app, injected) = (from_app & only, injected & only);
        // Evaluated only where a state sent reads them (a bind's settle evaluates one state).
        let converted = from_app.contains(States::CLIP_CONTROL)
            && self.path == DrawPath::Precise
            && matches!(
                self.derived_use(),
                Some((_, DepthConvention::NegativeOneToOne))
            );
        // A precise-path draw of a stage with the carrier baked in stores complementary depth
        // whatever n / f is known (found in review).
        let reversal = if (from_app | injected).intersects(States::BOUNDS | States::CLAMP_RANGE)
            && !(self.path == DrawPath::Precise && self.draws_baked())
        {
            self.target_reversing().reversal
        } else {
            Reversal::Complementary
        };
        let reversed = self.target == Target::Reversed;
        let sink = &mut Filtered {
            sink,
            last: &mut self.emitted,
        };
        let pick = |state: States| {
            if from_app.contains(state) {
                Some(true)
            } else if injected.contains(state) {
                Some(false)
            } else {
                None
            }
        };
        if let Some(app) = pick(States::COMPARE_OP) {
            let op = if app {
                self.compare_op
            } else {
                pipeline.map_or(self.compare_op, |p| p.compare_op)
            };
            sink.set_compare_op(if reversed { flip_compare_op(op) } else { op });
        }
        if let Some(app) = pick(States::BIAS) {
            let bias = if app {
                self.bias
            } else {
                pipeline.map_or(self.bias, |p| p.bias)
            };
            sink.set_bias(bias.for_attachment(reversed, self.promoted_from));
        }
        if from_app.contains(States::CLIP_CONTROL) {
            // The application's convention, but [0, 1] for a draw whose stage converts its
            // [-1, 1] line (`derived_use`).
            sink.set_clip_negative_one_to_one(self.clip_negative_one_to_one && !converted);
        }
        if let Some(app) = pick(States::BOUNDS) {
            let (min, max) = if app {
                self.bounds
            } else {
                pipeline.map_or(self.bounds, |p| p.bounds)
            };
            let (min, max) = if reversed {
                reversal.bounds(min, max)
            } else {
                (min, max)
            };
            sink.set_bounds(min, max);
        }
        if let Some(app) = pick(States::CLAMP_RANGE) {
            // revz makes a pipeline's clamp range dynamic only where it is user-defined.
            let range = if app {
                self.clamp_range
            } else {
                pipeline.map(|p| p.clamp_range)
            };
            // A clamp range holds depth values as stored: reversed, the same map as the
            // bounds (in infinite mode a clamping draw takes the flip path, whose map it is).
            let range = range.map(|(min, max)| {
                if reversed {
                    reversal.bounds(min, max)
                } else {
                    (min, max)
                }
            });
            sink.set_clamp_range(range);
        }
    }
}
