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

use ash::vk;
use revz_math::{Cameras, DepthConvention, Target as RewriteTarget};

use crate::conv::{flip_compare_op, DepthBias, Reversal};
use crate::objects::FragmentShader;
use crate::precise::{
    Carrier, FoldedPush, Outcome, ProjectionUse, PushConstants, PushSink, FLIP_CARRIER,
};
use crate::profile::{DrawCounts, DrawTally};
use crate::shader::derived_range::MatrixSource;

/// A set of depth-related dynamic states.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct States(u8);

impl States {
    pub const NONE: States = States(0);
    pub const VIEWPORT: States = States(1);
    pub const VIEWPORT_WITH_COUNT: States = States(2);
    pub const COMPARE_OP: States = States(4);
    pub const BIAS: States = States(8);
    pub const BOUNDS: States = States(16);
    /// `VK_EXT_depth_clip_control`'s convention, set with
    /// `vkCmdSetDepthClipNegativeOneToOneEXT` (Zink's [-1, 1] clip depth).
    pub const CLIP_CONTROL: States = States(32);
    pub const ALL: States = States(63);

    pub fn contains(self, other: States) -> bool {
        self.0 & other.0 == other.0
    }

    pub fn intersects(self, other: States) -> bool {
        self.0 & other.0 != 0
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The depth-related state a Vulkan dynamic state names, if any.
    pub fn of_dynamic(state: vk::DynamicState) -> States {
        match state {
            vk::DynamicState::VIEWPORT => States::VIEWPORT,
            vk::DynamicState::VIEWPORT_WITH_COUNT => States::VIEWPORT_WITH_COUNT,
            vk::DynamicState::DEPTH_COMPARE_OP => States::COMPARE_OP,
            vk::DynamicState::DEPTH_BIAS => States::BIAS,
            vk::DynamicState::DEPTH_BOUNDS => States::BOUNDS,
            vk::DynamicState::DEPTH_CLIP_NEGATIVE_ONE_TO_ONE_EXT => States::CLIP_CONTROL,
            _ => States::NONE,
        }
    }
}

impl std::ops::BitOr for States {
    type Output = States;
    fn bitor(self, rhs: States) -> States {
        States(self.0 | rhs.0)
    }
}

impl std::ops::BitOrAssign for States {
    fn bitor_assign(&mut self, rhs: States) {
        self.0 |= rhs.0;
    }
}

impl std::ops::BitAnd for States {
    type Output = States;
    fn bitand(self, rhs: States) -> States {
        States(self.0 & rhs.0)
    }
}

/// The most viewports revz tracks (`maxViewports` is 16 on every current driver).
pub const MAX_VIEWPORTS: usize = 16;

/// A pipeline's contribution to depth state.
#[derive(Clone, Debug, Default)]
pub struct PipelineDepth {
    /// States the application made dynamic: their values come from `vkCmdSet*`.
    pub app_dynamic: States,
    /// States revz made dynamic: their values are the application's static ones below.
    pub injected: States,
    pub viewports: Vec<vk::Viewport>,
    pub compare_op: vk::CompareOp,
    pub bias: DepthBias,
    pub bounds: (f32, f32),
    /// The fragment stage computes with depth (`FragDepth`, `FragCoord.z`) and no reversed
    /// variant rewrites it: draws into reversed attachments keep standard depth there.
    pub unreversed_fragment: bool,
    /// The pipeline itself.
    pub handle: vk::Pipeline,
    /// The pipeline bound in its place for draws into reversed attachments: the same pipeline
    /// with its static compare op flipped where the compare op is not made dynamic
    /// (`compare_op = variants`, or a device without extended dynamic state), and its
    /// fragment shader rewritten where it computes with depth (`crate::shader::fragment_depth`).
    pub reversed_variant: Option<vk::Pipeline>,
    /// The pipeline's render pass or rendering formats have a UNORM depth format revz
    /// promotes: draws into promoted attachments need the promoted variants below.
    pub promotable: bool,
    /// The pipeline made for the promoted twin of its render pass (or the float formats of its
    /// rendering formats), bound for draws into promoted attachments
    /// (`crate::policy::DevicePolicy::promoted_format`).
    pub promoted_variant: Option<vk::Pipeline>,
    /// The promoted variant with the reversed variant's changes, where the pipeline has both;
    /// draws into promoted reversed attachments.
    pub promoted_reversed_variant: Option<vk::Pipeline>,
    /// Where the vertex stage's projection is in the push constants, if it comes from there
    /// and its draws can take the precise path (its vertex stage stores the carrier's depth:
    /// [`PipelineDepth::position_store`]).
    pub projection: Option<ProjectionUse>,
    /// The pipeline's vertex stage (the application's pipeline's and its variant's) stores
    /// `Position` through revz's carrier ([`crate::shader::position_store`]): every draw needs the
    /// carrier to hold its values (the camera's on the precise path,
    /// [`crate::precise::FLIP_CARRIER`], the shader's own z, everywhere else).
    pub position_store: Option<Carrier>,
    /// The vertex stage derives its range from the matrix it loads (no projection in push
    /// constants: `crate::shader::derived_range`), and where that matrix comes from: its draws into
    /// reversed attachments push the selector of the mode instead of a camera's values.
    pub derived_range: Option<MatrixSource>,
    /// revz's own layout with the pipeline layout's push-constant ranges
    /// (`crate::objects::DeviceObjects::layout_pushers`): what revz pushes the carrier with
    /// for a stage that derives its range (the application may push nothing for it, or last
    /// pushed with another pipeline's layout), and before the application's first push.
    pub layout: vk::PipelineLayout,
    /// The state subsets the pipeline defines itself (`VK_EXT_graphics_pipeline_library`):
    /// all of them but for libraries, whose links take each subset's state from the library
    /// that defines it.
    pub subsets: vk::GraphicsPipelineLibraryFlagsEXT,
    /// A stage of the pipeline, or of a library it links, is given by a shader module
    /// identifier (`VK_EXT_shader_module_identifier`): what links it must keep
    /// `FAIL_ON_PIPELINE_COMPILE_REQUIRED`, so it gets no reversed variant.
    pub module_identifiers: bool,
}

impl PipelineDepth {
    /// The variant revz binds in the pipeline's place for a draw into a `reversed` and
    /// `promoted` attachment (`None`: the pipeline itself).
    pub fn variant_for(&self, reversed: bool, promoted: bool) -> Option<vk::Pipeline> {
        match (promoted && self.promotable, reversed) {
            (false, false) => None,
            (false, true) => self.reversed_variant,
            (true, false) => self.promoted_variant,
            (true, true) => self.promoted_reversed_variant.or(self.promoted_variant),
        }
    }

    /// The pipelines revz made for this one (to destroy with it).
    pub fn variants(&self) -> impl Iterator<Item = vk::Pipeline> {
        [
            self.reversed_variant,
            self.promoted_variant,
            self.promoted_reversed_variant,
        ]
        .into_iter()
        .flatten()
    }
}

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

impl Default for Reversing {
    fn default() -> Self {
        Reversing {
            rewrite: None,
            reversal: Reversal::Complementary,
        }
    }
}

/// Where [`CommandState::before_draw`] sends state (the next layer, in production).
pub trait StateSink: PushSink {
    fn set_viewports(&mut self, first: u32, viewports: &[vk::Viewport]);
    fn set_viewports_with_count(&mut self, viewports: &[vk::Viewport]);
    fn set_compare_op(&mut self, op: vk::CompareOp);
    fn set_bias(&mut self, bias: DepthBias);
    fn set_bounds(&mut self, min: f32, max: f32);
    /// `vkCmdSetDepthClipNegativeOneToOneEXT`.
    fn set_clip_negative_one_to_one(&mut self, negative_one_to_one: bool);
    /// Binds a graphics pipeline (a compare-op variant, or the application's pipeline back).
    fn bind_pipeline(&mut self, pipeline: vk::Pipeline);
    /// Binds a shader object to the fragment stage (a reversed variant, or the application's
    /// shader back).
    fn bind_fragment_shader(&mut self, shader: vk::ShaderEXT);
}

/// What revz last sent down for each depth-related dynamic state, so that a draw whose state
/// was re-evaluated (a pipeline bind, a push that changed the path) sends only what changed: on
/// a driver that records every `vkCmdSet*` as a command, redundant ones cost as much as the
/// layer's own work.
#[derive(Clone, Copy, Debug, Default)]
struct Emitted {
    /// The last viewport call.
    viewports: Option<SentViewports>,
    compare_op: Option<vk::CompareOp>,
    bias: Option<DepthBias>,
    bounds: Option<(u32, u32)>,
    clip_negative_one_to_one: Option<bool>,
}

impl Emitted {
    /// Forgets the states a newly bound pipeline sets statically (binding it overwrites them).
    fn forget_static(&mut self, dynamic: States) {
        if !dynamic.intersects(States::VIEWPORT | States::VIEWPORT_WITH_COUNT) {
            self.viewports = None;
        }
        if !dynamic.contains(States::COMPARE_OP) {
            self.compare_op = None;
        }
        if !dynamic.contains(States::BIAS) {
            self.bias = None;
        }
        if !dynamic.contains(States::BOUNDS) {
            self.bounds = None;
        }
        if !dynamic.contains(States::CLIP_CONTROL) {
            self.clip_negative_one_to_one = None;
        }
    }
}

/// A viewport call as sent: with count or not, the first viewport, and the bits of the
/// viewports (only the first `count` entries of `bits` mean anything). Compared and written
/// for the viewports sent only: a settle runs at every bind.
#[derive(Clone, Copy, Debug)]
struct SentViewports {
    with_count: bool,
    first: u32,
    count: u32,
    bits: [[u32; 6]; MAX_VIEWPORTS],
}

fn viewport_bits(v: &vk::Viewport) -> [u32; 6] {
    [v.x, v.y, v.width, v.height, v.min_depth, v.max_depth].map(f32::to_bits)
}

impl SentViewports {
    fn is(&self, with_count: bool, first: u32, viewports: &[vk::Viewport]) -> bool {
        self.with_count == with_count
            && self.first == first
            && self.count as usize == viewports.len()
            && self
                .bits
                .iter()
                .zip(viewports)
                .all(|(bits, v)| *bits == viewport_bits(v))
    }

    /// Records the call in `slot`, unless it is the one recorded: whether it must be sent.
    fn record(
        slot: &mut Option<SentViewports>,
        with_count: bool,
        first: u32,
        viewports: &[vk::Viewport],
    ) -> bool {
        if slot
            .as_ref()
            .is_some_and(|sent| sent.is(with_count, first, viewports))
        {
            return false;
        }
        let sent = slot.get_or_insert(SentViewports {
            with_count,
            first,
            count: 0,
            bits: [[0; 6]; MAX_VIEWPORTS],
        });
        sent.with_count = with_count;
        sent.first = first;
        sent.count = viewports.len().min(MAX_VIEWPORTS) as u32;
        for (bits, v) in sent.bits.iter_mut().zip(viewports) {
            *bits = viewport_bits(v);
        }
        true
    }
}

/// A [`StateSink`] that drops what would re-send the values last sent.
struct Filtered<'a, S> {
    sink: &'a mut S,
    last: &'a mut Emitted,
}

impl<S: StateSink> PushSink for Filtered<'_, S> {
    fn push_constants(
        &mut self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        bytes: &[u8],
    ) {
        self.sink.push_constants(layout, stages, offset, bytes);
    }
}

impl<S: StateSink> StateSink for Filtered<'_, S> {
    fn set_viewports(&mut self, first: u32, viewports: &[vk::Viewport]) {
        if SentViewports::record(&mut self.last.viewports, false, first, viewports) {
            self.sink.set_viewports(first, viewports);
        }
    }

    fn set_viewports_with_count(&mut self, viewports: &[vk::Viewport]) {
        if SentViewports::record(&mut self.last.viewports, true, 0, viewports) {
            self.sink.set_viewports_with_count(viewports);
        }
    }

    fn set_compare_op(&mut self, op: vk::CompareOp) {
        if self.last.compare_op != Some(op) {
            self.last.compare_op = Some(op);
            self.sink.set_compare_op(op);
        }
    }

    fn set_bias(&mut self, bias: DepthBias) {
        if self.last.bias != Some(bias) {
            self.last.bias = Some(bias);
            self.sink.set_bias(bias);
        }
    }

    fn set_bounds(&mut self, min: f32, max: f32) {
        let bits = (min.to_bits(), max.to_bits());
        if self.last.bounds != Some(bits) {
            self.last.bounds = Some(bits);
            self.sink.set_bounds(min, max);
        }
    }

    fn set_clip_negative_one_to_one(&mut self, negative_one_to_one: bool) {
        if self.last.clip_negative_one_to_one != Some(negative_one_to_one) {
            self.last.clip_negative_one_to_one = Some(negative_one_to_one);
            self.sink.set_clip_negative_one_to_one(negative_one_to_one);
        }
    }

    fn bind_pipeline(&mut self, pipeline: vk::Pipeline) {
        // A variant has the dynamic states of the pipeline it stands for: binding it
        // overwrites nothing the record holds.
        self.sink.bind_pipeline(pipeline);
    }

    fn bind_fragment_shader(&mut self, shader: vk::ShaderEXT) {
        // Shader objects have no static state.
        self.sink.bind_fragment_shader(shader);
    }
}

/// How many pipelines a recording keeps by handle for its binds.
const KNOWN_PIPELINES: usize = 4;

/// The graphics pipelines a recording bound, with their depth state (`None`: not tracked),
/// found by handle: binding one of them again looks nothing up in the device's table (a shared
/// lock) and takes no reference count. Valid under the device's pipeline generation they were
/// found in (`DeviceObjects::pipeline_generation`): a pipeline destroyed anywhere on the
/// device empties them at the next bind.
#[derive(Clone, Debug, Default)]
struct KnownPipelines {
    generation: u64,
    slots: [(vk::Pipeline, Option<std::sync::Arc<PipelineDepth>>); KNOWN_PIPELINES],
    /// The slot the next pipeline not found replaces.
    next: usize,
}

impl KnownPipelines {
    /// The slot holding `handle`, found with `lookup` where this recording does not know it.
    fn slot(
        &mut self,
        handle: vk::Pipeline,
        generation: u64,
        lookup: impl FnOnce() -> Option<std::sync::Arc<PipelineDepth>>,
    ) -> usize {
        if self.generation != generation {
            *self = KnownPipelines {
                generation,
                ..KnownPipelines::default()
            };
        } else if let Some(index) = self
            .slots
            .iter()
            .position(|(known, _)| *known == handle && handle != vk::Pipeline::null())
        {
            return index;
        }
        self.insert(handle, lookup())
    }

    fn insert(
        &mut self,
        handle: vk::Pipeline,
        depth: Option<std::sync::Arc<PipelineDepth>>,
    ) -> usize {
        let index = self.next;
        self.next = (index + 1) % KNOWN_PIPELINES;
        self.slots[index] = (handle, depth);
        index
    }
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
    /// Which states the application set with `vkCmdSet*`.
    app_set: States,
    reversing: Reversing,
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
    /// The application pushed since the last graphics bind: with a layout the bound pipeline
    /// is not compatible with, it pushes for the next pipeline, and revz's carrier must not
    /// go down over its bytes now (it goes with the next compatible push or bind).
    pushed_since_bind: bool,
    /// The shader object the application bound to the fragment stage (null: none), and what
    /// revz knows of it when it computes with depth.
    fragment_shader: (vk::ShaderEXT, Option<FragmentShader>),
    /// Whether revz bound the bound fragment shader object's reversed variant in its place.
    shader_variant_bound: bool,
    /// A secondary that inherits its viewports from the primary that executes it
    /// (`VK_NV_inherited_viewport_scissor`): its draws take the flip path, the one the
    /// primary sends its viewports for ([`CommandState::flush_viewports_for_secondaries`]).
    inherits_viewports: bool,
    /// The current subpass (or rendering instance) records its draws in secondaries: no
    /// state command may be recorded in it.
    secondary_contents: bool,
    /// Draws can be recorded now: inside a render pass or rendering instance, or in a
    /// secondary that continues one. State is only sent down here ([`Self::settle`]).
    in_pass: bool,
    dirty: bool,
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
            app_set: States::NONE,
            reversing: Reversing::default(),
            push: PushConstants::default(),
            path: DrawPath::Native,
            draws: DrawTally::default(),
            executed_matches: Vec::new(),
            emitted: Emitted::default(),
            variant_bound: None,
            promoted_from: None,
            carrier_held: None,
            push_pusher: vk::PipelineLayout::null(),
            pushed_since_bind: false,
            fragment_shader: (vk::ShaderEXT::null(), None),
            shader_variant_bound: false,
            inherits_viewports: false,
            secondary_contents: false,
            in_pass: false,
            dirty: true,
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

    /// The projection the bound pipeline's draws would rewrite now, if any.
    fn precise_use(&self) -> Option<(&ProjectionUse, RewriteTarget)> {
        if self.target != Target::Reversed || self.inherits_viewports {
            return None;
        }
        let projection = self.pipeline()?.projection.as_ref()?;
        Some((projection, self.reversing.rewrite?))
    }

    /// The mode whose depth the bound pipeline's vertex stage derives itself for the next
    /// draw, if it does (`crate::shader::derived_range`): a reversed attachment, viewports of its own,
    /// a rewriting mode, and a stage that derives its range.
    fn derived_use(&self) -> Option<(RewriteTarget, DepthConvention)> {
        if self.target != Target::Reversed || self.inherits_viewports {
            return None;
        }
        let pipeline = self.pipeline()?;
        pipeline.derived_range?;
        // A dynamic [-1, 1] clip convention (Zink): the stage converts its fitted line, and
        // revz sets [0, 1] for the draw ([`Self::emit`]), where reversed depth near 0 keeps
        // float32's resolution.
        let convention = if pipeline.app_dynamic.contains(States::CLIP_CONTROL)
            && self.app_set.contains(States::CLIP_CONTROL)
            && self.clip_negative_one_to_one
        {
            DepthConvention::NegativeOneToOne
        } else {
            DepthConvention::ZeroToOne
        };
        Some((self.reversing.rewrite?, convention))
    }

    /// The application's next push uses a layout whose push ranges revz's layout `pusher`
    /// has (null: unknown); called before [`Self::push_constants`] when the layout changes.
    pub fn note_push_pusher(&mut self, pusher: vk::PipelineLayout) {
        self.push_pusher = pusher;
    }

    /// The application's last push layout, null before its first push.
    pub fn push_layout(&self) -> vk::PipelineLayout {
        self.push.layout()
    }

    /// Whether the application's last push layout is push-compatible with the bound
    /// pipeline's (unknown counts as compatible: pipelines without revz's layout).
    fn push_compatible(&self) -> bool {
        let own = self
            .pipeline()
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
        let Some((use_, target)) = self.precise_use().map(|(p, t)| (*p, t)) else {
            return (None, self.fold(layout, stages, offset, None));
        };
        let end = u64::from(offset) + data.len() as u64;
        if end <= u64::from(use_.offset) || u64::from(use_.end()) <= u64::from(offset) {
            return (None, self.fold(layout, stages, offset, None));
        }
        let outcome = self.push.outcome(&use_, target);
        match outcome {
            Some(outcome) => {
                self.learn(&outcome);
                let path = match outcome {
                    Outcome::Rewritten { .. } => DrawPath::Precise,
                    _ => DrawPath::Flip,
                };
                if path != self.path {
                    self.dirty = true;
                }
            }
            None => self.dirty = true,
        }
        (outcome, self.fold(layout, stages, offset, outcome))
    }

    /// The bytes of a push [`Self::push_constants`] just returned, written into `out`.
    pub fn folded_bytes<'a>(
        &self,
        folded: &FoldedPush,
        out: &'a mut [u8; crate::precise::PUSH_CONSTANT_BYTES],
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
        let carrier = self.pipeline()?.position_store?;
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
    fn carrier_values(&self, outcome: Option<Outcome>) -> [f32; 4] {
        if let Some((target, convention)) = self.derived_use() {
            return derived_selector(target, convention);
        }
        match (self.target, outcome) {
            (Target::Reversed, Some(Outcome::Rewritten { carrier, .. })) => carrier,
            _ => FLIP_CARRIER,
        }
    }

    /// Infinite mode: a rewritten projection tells n / f, which flip-path state follows.
    fn learn(&mut self, outcome: &Outcome) {
        if let (Outcome::Rewritten { near_over_far, .. }, Reversal::Infinite { near_over_far: r }) =
            (outcome, &mut self.reversing.reversal)
        {
            if !same_near_over_far(*r, *near_over_far) {
                *r = *near_over_far;
                // Only flip-path viewports and depth bounds depend on it.
                let bounds = self
                    .pipeline()
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

    /// The render pass or rendering instance ended: no draw can be recorded until the next,
    /// and nothing is sent down before it ([`Self::settle`]).
    pub fn leave_pass(&mut self) {
        self.in_pass = false;
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
        let wanted = pipeline.variant_for(self.target == Target::Reversed, self.promoted());
        self.variant_bound = wanted;
        wanted.unwrap_or(app)
    }

    /// `vkCmdBindPipeline` with a graphics pipeline: it unbinds the shader objects bound to
    /// graphics stages (revz's fragment variant with them).
    pub fn bind_pipeline(&mut self, pipeline: Option<std::sync::Arc<PipelineDepth>>) {
        let handle = pipeline.as_ref().map_or(vk::Pipeline::null(), |p| p.handle);
        let slot = self.known.insert(handle, pipeline);
        self.bind_slot(Some(slot));
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
        let slot = self.known.slot(handle, generation, lookup);
        self.bind_slot(Some(slot));
    }

    fn bind_slot(&mut self, slot: Option<usize>) {
        self.bind_graphics(slot);
        self.fragment_shader = (vk::ShaderEXT::null(), None);
        self.shader_variant_bound = false;
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
    /// variant revz bound stays in place of the application's shader).
    pub fn bind_shaders(&mut self, fragment: Option<(vk::ShaderEXT, Option<FragmentShader>)>) {
        self.bind_graphics(None);
        if let Some(fragment) = fragment {
            // The application's bind goes down after this: its shader is the one bound now.
            self.fragment_shader = fragment;
            self.shader_variant_bound = false;
        }
    }

    /// A pipeline (`None`: untracked, or shader objects) becomes the source of static state.
    fn bind_graphics(&mut self, slot: Option<usize>) {
        self.bound = slot;
        // An untracked pipeline (or shader objects) may set anything statically.
        let dynamic = self
            .pipeline()
            .map_or(States::NONE, |p| p.app_dynamic | p.injected);
        self.emitted.forget_static(dynamic);
        self.variant_bound = None;
        self.pushed_since_bind = false;
        self.dirty = true;
    }

    /// A secondary begun with `VkCommandBufferInheritanceViewportScissorInfoNV`
    /// (`viewportScissor2D`): its viewports come from the primary, which sends them for the
    /// flip path, so its draws take the flip path too.
    pub fn inherit_viewports(&mut self) {
        self.inherits_viewports = true;
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
        let sink = &mut Filtered {
            sink,
            last: &mut self.emitted,
        };
        self.viewports
            .emit(sink, path, self.reversing.reversal, self.app_set, None);
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

    /// `vkCmdSetDepthClipNegativeOneToOneEXT`.
    pub fn set_clip_negative_one_to_one(&mut self, negative_one_to_one: bool) {
        self.clip_negative_one_to_one = negative_one_to_one;
        self.app_set |= States::CLIP_CONTROL;
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

    /// Whether [`Self::settle`] would send anything: state changed since the last settle, in a
    /// pass where draws are recorded inline.
    #[inline]
    pub fn wants_settle(&self) -> bool {
        self.dirty && self.in_pass && !self.secondary_contents
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
        let store = self.pipeline().and_then(|p| p.position_store);
        // A stage that derives its range: revz's own layout with the pipeline's push ranges
        // (the application may push nothing for it, or last pushed with another pipeline's
        // layout). Before the application's first push, the same.
        let own = self
            .pipeline()
            .map_or(vk::PipelineLayout::null(), |p| p.layout);
        let derived = self.pipeline().is_some_and(|p| p.derived_range.is_some());
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
            (Target::Reversed, _) if carrier_ready && self.derived_use().is_some() => {
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
        outcome
    }

    fn emit(&mut self, sink: &mut impl StateSink) {
        let converted = self.path == DrawPath::Precise
            && matches!(
                self.derived_use(),
                Some((_, DepthConvention::NegativeOneToOne))
            );
        // Only what changed since it was last sent goes down (closures below capture only
        // the fields they read, so the record is borrowed apart from them).
        // The bound pipeline, borrowed apart from the fields written below.
        let bound = self
            .bound
            .and_then(|slot| self.known.slots[slot].1.as_ref());
        let sink = &mut Filtered {
            sink,
            last: &mut self.emitted,
        };
        let reversed = self.target == Target::Reversed;
        let reversal = self.reversing.reversal;
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
            let wanted = p.variant_for(reversed, self.promoted_from.is_some());
            if wanted != self.variant_bound {
                sink.bind_pipeline(wanted.unwrap_or(p.handle));
                self.variant_bound = wanted;
            }
        }
        match self.fragment_shader {
            (shader, Some(FragmentShader::Reversed(variant)))
                if reversed != self.shader_variant_bound =>
            {
                sink.bind_fragment_shader(if reversed { variant } else { shader });
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
        let (from_app, injected, pipeline) = match bound {
            Some(p) => (self.app_set & p.app_dynamic, p.injected, Some(&**p)),
            None => (self.app_set, States::NONE, None),
        };

        self.viewports
            .emit(sink, self.path, reversal, from_app, pipeline);

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
            let bias = match self.promoted_from {
                Some(format) => bias.in_float_storage(format),
                None => bias,
            };
            sink.set_bias(if reversed { bias.flipped() } else { bias });
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
    }
}

/// The viewports the application set in a command buffer.
#[derive(Clone, Copy, Debug)]
struct AppViewports {
    values: [vk::Viewport; MAX_VIEWPORTS],
    /// Which of `values` were set with `vkCmdSetViewport`.
    set: u16,
    /// The count of `vkCmdSetViewportWithCount`, if the application used it.
    count: Option<u32>,
}

impl Default for AppViewports {
    fn default() -> Self {
        AppViewports {
            values: [vk::Viewport::default(); MAX_VIEWPORTS],
            set: 0,
            count: None,
        }
    }
}

impl AppViewports {
    /// Sends the viewports of a draw on `path`: the application's (`from_app` says which
    /// kind it set: with count, or by index), else the pipeline's static ones that revz made
    /// dynamic.
    fn emit(
        &self,
        sink: &mut impl StateSink,
        path: DrawPath,
        reversal: Reversal,
        from_app: States,
        pipeline: Option<&PipelineDepth>,
    ) {
        let viewport = |v: &vk::Viewport| match path {
            DrawPath::Native => *v,
            DrawPath::Flip => reversal.viewport(*v),
            DrawPath::Precise => reversal.precise_viewport(*v),
        };
        if from_app.contains(States::VIEWPORT_WITH_COUNT) {
            let count = self.count.unwrap_or(0) as usize;
            let mut out = [vk::Viewport::default(); MAX_VIEWPORTS];
            for (o, v) in out.iter_mut().zip(&self.values[..count]) {
                *o = viewport(v);
            }
            sink.set_viewports_with_count(&out[..count]);
        } else if from_app.contains(States::VIEWPORT) {
            // Emit each contiguous run of viewports the application set.
            let mut index = 0;
            while index < MAX_VIEWPORTS {
                if self.set & (1 << index) == 0 {
                    index += 1;
                    continue;
                }
                let start = index;
                let mut out = [vk::Viewport::default(); MAX_VIEWPORTS];
                while index < MAX_VIEWPORTS && self.set & (1 << index) != 0 {
                    out[index - start] = viewport(&self.values[index]);
                    index += 1;
                }
                sink.set_viewports(start as u32, &out[..index - start]);
            }
        } else if let Some(p) = pipeline.filter(|p| p.injected.contains(States::VIEWPORT)) {
            let mut out = [vk::Viewport::default(); MAX_VIEWPORTS];
            let count = p.viewports.len().min(MAX_VIEWPORTS);
            for (o, v) in out.iter_mut().zip(&p.viewports[..count]) {
                *o = viewport(v);
            }
            sink.set_viewports(0, &out[..count]);
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use ash::vk::Handle;

    use super::*;

    #[derive(Clone, Debug, Default, PartialEq)]
    struct Recorded {
        viewports: Vec<(u32, Vec<(f32, f32)>)>,
        with_count: Vec<Vec<(f32, f32)>>,
        compare_ops: Vec<vk::CompareOp>,
        biases: Vec<DepthBias>,
        bounds: Vec<(f32, f32)>,
        pushes: Vec<(u32, usize)>,
        /// The layout and bytes of each push.
        pushed: Vec<(vk::PipelineLayout, Vec<u8>)>,
        clip_conventions: Vec<bool>,
        binds: Vec<vk::Pipeline>,
        shader_binds: Vec<vk::ShaderEXT>,
    }

    impl PushSink for Recorded {
        fn push_constants(
            &mut self,
            layout: vk::PipelineLayout,
            _: vk::ShaderStageFlags,
            offset: u32,
            bytes: &[u8],
        ) {
            self.pushes.push((offset, bytes.len()));
            self.pushed.push((layout, bytes.to_vec()));
        }
    }

    impl StateSink for Recorded {
        fn set_viewports(&mut self, first: u32, viewports: &[vk::Viewport]) {
            let depths = viewports
                .iter()
                .map(|v| (v.min_depth, v.max_depth))
                .collect();
            self.viewports.push((first, depths));
        }
        fn set_viewports_with_count(&mut self, viewports: &[vk::Viewport]) {
            let depths = viewports
                .iter()
                .map(|v| (v.min_depth, v.max_depth))
                .collect();
            self.with_count.push(depths);
        }
        fn set_compare_op(&mut self, op: vk::CompareOp) {
            self.compare_ops.push(op);
        }
        fn set_bias(&mut self, bias: DepthBias) {
            self.biases.push(bias);
        }
        fn set_clip_negative_one_to_one(&mut self, negative_one_to_one: bool) {
            self.clip_conventions.push(negative_one_to_one);
        }

        fn set_bounds(&mut self, min: f32, max: f32) {
            self.bounds.push((min, max));
        }
        fn bind_pipeline(&mut self, pipeline: vk::Pipeline) {
            self.binds.push(pipeline);
        }
        fn bind_fragment_shader(&mut self, shader: vk::ShaderEXT) {
            self.shader_binds.push(shader);
        }
    }

    fn viewport(min_depth: f32, max_depth: f32) -> vk::Viewport {
        vk::Viewport {
            width: 256.0,
            height: 256.0,
            min_depth,
            max_depth,
            ..Default::default()
        }
    }

    /// A command buffer of a flip-mode device, begun with `target`.
    fn begun(target: Target) -> CommandState {
        let mut state = CommandState::default();
        state.begin(target, Reversal::Complementary, Cameras::default());
        state
    }

    /// A pipeline whose viewport and compare op were static and made dynamic by revz.
    fn static_pipeline() -> Arc<PipelineDepth> {
        Arc::new(PipelineDepth {
            app_dynamic: States::NONE,
            injected: States::VIEWPORT | States::COMPARE_OP | States::BIAS,
            viewports: vec![viewport(0.0, 1.0)],
            compare_op: vk::CompareOp::LESS,
            bias: DepthBias {
                constant: -1.0,
                clamp: 0.0,
                slope: -2.0,
            },
            bounds: (0.0, 1.0),
            unreversed_fragment: false,
            handle: vk::Pipeline::null(),
            reversed_variant: None,
            promotable: false,
            promoted_variant: None,
            promoted_reversed_variant: None,
            projection: None,
            position_store: None,
            derived_range: None,
            layout: vk::PipelineLayout::null(),
            subsets: vk::GraphicsPipelineLibraryFlagsEXT::empty(),
            module_identifiers: false,
        })
    }

    #[test]
    fn a_compare_op_variant_is_bound_for_reversed_draws_and_the_original_for_native_ones() {
        let original = vk::Pipeline::from_raw(10);
        let variant = vk::Pipeline::from_raw(11);
        let pipeline = Arc::new(PipelineDepth {
            injected: States::VIEWPORT,
            viewports: vec![viewport(0.0, 1.0)],
            compare_op: vk::CompareOp::LESS,
            handle: original,
            reversed_variant: Some(variant),
            ..PipelineDepth::default()
        });
        let mut state = begun(Target::Reversed);
        state.bind_pipeline(Some(Arc::clone(&pipeline)));
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        state.before_draw(&mut sink);
        assert_eq!(
            sink.binds,
            vec![variant],
            "bound once, for the reversed draws"
        );
        assert!(
            sink.compare_ops.is_empty(),
            "the variant holds the compare op"
        );
        assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.0)])]);

        // A native pass: the application's pipeline comes back.
        state.set_target(Target::Native);
        state.before_draw(&mut sink);
        assert_eq!(sink.binds, vec![variant, original]);

        // The application binds again (its own pipeline goes down): reversed draws need the
        // variant bound again; native ones need nothing.
        state.bind_pipeline(Some(Arc::clone(&pipeline)));
        state.before_draw(&mut sink);
        assert_eq!(sink.binds, vec![variant, original]);
        state.set_target(Target::Reversed);
        state.bind_pipeline(Some(pipeline));
        state.before_draw(&mut sink);
        assert_eq!(sink.binds, vec![variant, original, variant]);
    }

    /// A static pipeline (10) with a reversed variant (11).
    fn with_reversed_variant() -> (vk::Pipeline, vk::Pipeline, Arc<PipelineDepth>) {
        let original = vk::Pipeline::from_raw(10);
        let variant = vk::Pipeline::from_raw(11);
        let pipeline = Arc::new(PipelineDepth {
            handle: original,
            reversed_variant: Some(variant),
            ..(*static_pipeline()).clone()
        });
        (original, variant, pipeline)
    }

    #[test]
    fn state_settles_inside_passes_only_and_a_variant_goes_down_in_the_binds_place() {
        let (original, variant, pipeline) = with_reversed_variant();
        // A primary, outside any pass: the bind goes down as the application's, and nothing
        // else is sent (no draw can follow before a begin).
        let mut state = CommandState::default();
        state.begin(Target::None, Reversal::Complementary, Cameras::default());
        state.bind_pipeline(Some(Arc::clone(&pipeline)));
        assert_eq!(state.pipeline_to_bind(original), original);
        state.set_compare_op(vk::CompareOp::LESS);
        let mut sink = Recorded::default();
        assert!(state.settle(&mut sink).is_none());
        assert_eq!(sink, Recorded::default(), "nothing outside a pass");
        // The pass begins into a reversed attachment: everything the next draw needs goes
        // down once, as the begin settles, and a draw then sends nothing.
        state.set_target(Target::Reversed);
        state.settle(&mut sink);
        assert_eq!(sink.binds, vec![variant]);
        assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.0)])]);
        assert_eq!(sink.biases.len(), 1);
        let sent = sink.clone();
        state.settle(&mut sink);
        state.before_draw(&mut sink);
        assert_eq!(sink, sent, "nothing more for the draw");
        // A bind inside the pass: the variant is what goes down, and nothing after it.
        state.bind_pipeline(Some(Arc::clone(&pipeline)));
        assert_eq!(state.pipeline_to_bind(original), variant);
        state.settle(&mut sink);
        assert_eq!(sink.binds, vec![variant], "no second bind");
        // Inside a subpass of secondaries nothing may be recorded: it waits.
        state.set_secondary_contents(true);
        state.set_target(Target::Native);
        state.settle(&mut sink);
        assert_eq!(sink.binds, vec![variant]);
        state.set_secondary_contents(false);
        state.settle(&mut sink);
        assert_eq!(sink.binds, vec![variant, original]);
        // The pass ends: nothing goes down until the next begin.
        state.leave_pass();
        state.set_compare_op(vk::CompareOp::GREATER);
        let sent = sink.clone();
        state.settle(&mut sink);
        assert_eq!(sink, sent);
    }

    #[test]
    fn a_push_revz_cannot_follow_keeps_the_variant_it_bound_in_mind() {
        let (original, variant, pipeline) = with_reversed_variant();
        let mut state = begun(Target::Reversed);
        state.bind_pipeline(Some(pipeline));
        assert_eq!(state.pipeline_to_bind(original), variant);
        let mut sink = Recorded::default();
        state.settle(&mut sink);
        // `vkCmdPushConstants2` with its layout in pNext: the pushes are unknown, the bound
        // pipeline is not. A later native target must bind the application's pipeline back
        // (forgetting the variant would leave it bound into a native attachment).
        state.forget_push_constants();
        state.settle(&mut sink);
        assert!(sink.binds.is_empty(), "{:?}", sink.binds);
        state.set_target(Target::Native);
        state.settle(&mut sink);
        assert_eq!(sink.binds, vec![original]);
    }

    #[test]
    fn a_fragment_shader_objects_variant_is_bound_for_reversed_draws_and_the_app_shader_back() {
        let shader = vk::ShaderEXT::from_raw(20);
        let variant = vk::ShaderEXT::from_raw(21);
        let fragment = Some((shader, Some(FragmentShader::Reversed(variant))));
        let mut state = begun(Target::Reversed);
        state.bind_shaders(fragment);
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        state.before_draw(&mut sink);
        assert_eq!(
            sink.shader_binds,
            [variant],
            "bound once, for reversed draws"
        );
        assert!(sink.binds.is_empty());

        // Binding other stages leaves the variant in place of the application's shader.
        state.bind_shaders(None);
        state.before_draw(&mut sink);
        assert_eq!(sink.shader_binds, [variant]);

        // A native pass: the application's shader comes back, once.
        state.set_target(Target::Native);
        state.before_draw(&mut sink);
        state.before_draw(&mut sink);
        assert_eq!(sink.shader_binds, [variant, shader]);

        // The application binds its shader again (it goes down): native draws need nothing,
        // reversed ones the variant again.
        state.bind_shaders(fragment);
        state.before_draw(&mut sink);
        assert_eq!(sink.shader_binds, [variant, shader]);
        state.set_target(Target::Reversed);
        state.before_draw(&mut sink);
        assert_eq!(sink.shader_binds, [variant, shader, variant]);

        // Secondaries leave the bindings undefined: the variant is bound again.
        state.invalidate();
        state.before_draw(&mut sink);
        assert_eq!(sink.shader_binds, [variant, shader, variant, variant]);
    }

    #[test]
    fn unbinding_the_fragment_shader_or_binding_a_pipeline_forgets_its_variant() {
        let shader = vk::ShaderEXT::from_raw(30);
        let variant = vk::ShaderEXT::from_raw(31);
        let fragment = Some((shader, Some(FragmentShader::Reversed(variant))));
        let mut state = begun(Target::Reversed);
        let mut sink = Recorded::default();

        // Unbound (null): nothing to swap.
        state.bind_shaders(fragment);
        state.bind_shaders(Some((vk::ShaderEXT::null(), None)));
        state.before_draw(&mut sink);
        assert!(sink.shader_binds.is_empty());

        // A pipeline bound after the variant unbinds it: native draws bind nothing back.
        state.bind_shaders(fragment);
        state.before_draw(&mut sink);
        assert_eq!(sink.shader_binds, [variant]);
        state.bind_pipeline(Some(static_pipeline()));
        state.before_draw(&mut sink);
        state.set_target(Target::Native);
        state.before_draw(&mut sink);
        assert_eq!(sink.shader_binds, [variant]);

        // Shaders without a variant (plain, or marked unreversed) are never swapped.
        for depth in [None, Some(FragmentShader::Unreversed)] {
            state.set_target(Target::Reversed);
            state.bind_shaders(Some((shader, depth)));
            state.before_draw(&mut sink);
            state.set_target(Target::Native);
            state.before_draw(&mut sink);
        }
        assert_eq!(sink.shader_binds, [variant]);
    }

    #[test]
    fn static_state_is_emitted_flipped_for_a_reversed_target_once() {
        let mut state = begun(Target::Reversed);
        state.bind_pipeline(Some(static_pipeline()));
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        state.before_draw(&mut sink);
        assert_eq!(
            sink,
            Recorded {
                viewports: vec![(0, vec![(1.0, 0.0)])],
                compare_ops: vec![vk::CompareOp::GREATER],
                biases: vec![DepthBias {
                    constant: 1.0,
                    clamp: -0.0,
                    slope: 2.0
                }],
                ..Default::default()
            }
        );
    }

    #[test]
    fn native_targets_get_the_application_values_unchanged() {
        let mut state = begun(Target::Native);
        state.bind_pipeline(Some(static_pipeline()));
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(sink.viewports, vec![(0, vec![(0.0, 1.0)])]);
        assert_eq!(sink.compare_ops, vec![vk::CompareOp::LESS]);
        assert_eq!(sink.biases[0].constant, -1.0);
    }

    #[test]
    fn application_dynamic_state_is_flipped_and_reemitted_when_the_target_changes() {
        let mut state = begun(Target::None);
        state.bind_pipeline(Some(Arc::new(PipelineDepth {
            app_dynamic: States::VIEWPORT | States::COMPARE_OP | States::BOUNDS,
            ..PipelineDepth::default()
        })));
        state.set_viewports(0, &[viewport(0.0, 0.5), viewport(0.5, 1.0)]);
        state.set_compare_op(vk::CompareOp::LESS_OR_EQUAL);
        state.set_bounds(0.0, 0.75);
        state.set_target(Target::Reversed);
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.5), (0.5, 0.0)])]);
        assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER_OR_EQUAL]);
        assert_eq!(sink.bounds, vec![(0.25, 1.0)]);

        state.set_target(Target::Native);
        state.before_draw(&mut sink);
        assert_eq!(sink.compare_ops.last(), Some(&vk::CompareOp::LESS_OR_EQUAL));
        assert_eq!(
            sink.viewports.last(),
            Some(&(0, vec![(0.0, 0.5), (0.5, 1.0)]))
        );
    }

    #[test]
    fn only_viewports_the_application_set_are_emitted() {
        let mut state = begun(Target::Reversed);
        state.set_viewports(2, &[viewport(0.0, 0.1)]);
        state.set_viewports(4, &[viewport(0.0, 1.0), viewport(0.25, 0.5)]);
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(
            sink.viewports,
            vec![(2, vec![(1.0, 0.9)]), (4, vec![(1.0, 0.0), (0.75, 0.5)])]
        );
    }

    #[test]
    fn states_the_pipeline_keeps_static_are_not_emitted() {
        let mut state = begun(Target::Reversed);
        state.set_compare_op(vk::CompareOp::LESS);
        state.set_viewports_with_count(&[viewport(0.0, 1.0)]);
        state.bind_pipeline(Some(Arc::new(PipelineDepth {
            app_dynamic: States::VIEWPORT_WITH_COUNT,
            ..PipelineDepth::default()
        })));
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(sink.with_count, vec![vec![(1.0, 0.0)]]);
        assert!(sink.compare_ops.is_empty() && sink.viewports.is_empty());
    }

    #[test]
    fn without_a_tracked_pipeline_every_set_state_is_emitted() {
        // Shader objects, or a pipeline revz could not read: the application's dynamic state
        // must still reach the driver.
        let mut state = begun(Target::Native);
        state.set_compare_op(vk::CompareOp::GREATER);
        state.set_bias(DepthBias {
            constant: 3.0,
            ..Default::default()
        });
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER]);
        assert_eq!(sink.biases.len(), 1);
    }

    fn perspective_bytes() -> Vec<u8> {
        let projection = glam::dcamera::rh::proj::vulkan::perspective(1.0, 1.5, 0.5, 50.0);
        projection
            .as_mat4()
            .to_cols_array()
            .iter()
            .flat_map(|v| v.to_ne_bytes())
            .collect()
    }

    const APP_PIPELINE: u64 = 8;
    /// Push stages other than the carrier's range's: such pushes never carry the carrier.
    const OTHER_STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
        vk::ShaderStageFlags::VERTEX.as_raw() | vk::ShaderStageFlags::FRAGMENT.as_raw(),
    );

    /// A pipeline reading its projection from push-constant bytes 0..64, whose vertex stage
    /// stores the carrier's depth (carrier at byte 112).
    fn projection_pipeline() -> Arc<PipelineDepth> {
        Arc::new(PipelineDepth {
            projection: Some(ProjectionUse {
                offset: 0,
                stride: 16,
                storage: revz_math::Storage::ColumnMajor,
                convention: revz_math::DepthConvention::ZeroToOne,
            }),
            position_store: Some(Carrier {
                offset: 112,
                stages: vk::ShaderStageFlags::VERTEX,
                range_offset: 0,
            }),
            handle: vk::Pipeline::from_raw(APP_PIPELINE),
            ..(*static_pipeline()).clone()
        })
    }

    fn layout() -> vk::PipelineLayout {
        vk::PipelineLayout::from_raw(3)
    }

    fn precise(target: RewriteTarget) -> CommandState {
        let reversal = match target {
            RewriteTarget::Complementary => Reversal::Complementary,
            RewriteTarget::Infinite => Reversal::Infinite { near_over_far: 0.0 },
        };
        CommandState::new(Reversing {
            rewrite: Some(target),
            reversal,
        })
    }

    /// A pipeline whose vertex stage derives its range from a uniform buffer's matrix.
    fn derived_pipeline() -> Arc<PipelineDepth> {
        Arc::new(PipelineDepth {
            projection: None,
            derived_range: Some(MatrixSource::UniformBuffer),
            layout: vk::PipelineLayout::from_raw(9),
            ..(*projection_pipeline()).clone()
        })
    }

    #[test]
    fn a_stage_deriving_its_range_gets_the_selector_with_its_own_layout_and_no_push_of_its_own() {
        for (target, selector) in [
            (RewriteTarget::Complementary, 1.0f32),
            (RewriteTarget::Infinite, 2.0),
        ] {
            let reversal = precise(target).reversal();
            let mut state = precise(target);
            state.begin(Target::Reversed, reversal, Default::default());
            state.bind_pipeline(Some(derived_pipeline()));
            let mut sink = Recorded::default();
            state.before_draw(&mut sink);
            assert_eq!(state.path(), DrawPath::Precise);
            let carrier = Carrier::bytes(&[0.0, 0.0, 0.0, selector]).to_vec();
            assert_eq!(
                sink.pushed,
                vec![(vk::PipelineLayout::from_raw(9), carrier)]
            );
            assert_eq!(sink.viewports, vec![(0, vec![(0.0, 1.0)])]);
            assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER]);
            // The next draws: nothing more to send.
            state.before_draw(&mut sink);
            assert_eq!(sink.pushed.len(), 1);
            // Into a native attachment the stage stores its own z.
            state.set_target(Target::Native);
            state.before_draw(&mut sink);
            assert_eq!(state.path(), DrawPath::Native);
            let flip = Carrier::bytes(&FLIP_CARRIER).to_vec();
            assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&flip));
            // The application pushed with another pipeline's layout (an overlay's): the
            // selector still goes down with revz's layout of this pipeline's ranges.
            let mut state = precise(target);
            state.begin(Target::Reversed, reversal, Default::default());
            state.push_constants(layout(), OTHER_STAGES, 0, &[0; 16]);
            state.bind_pipeline(Some(derived_pipeline()));
            let mut sink = Recorded::default();
            state.before_draw(&mut sink);
            assert_eq!(
                sink.pushed.last().map(|p| p.0),
                Some(vk::PipelineLayout::from_raw(9))
            );
            // A secondary inheriting viewports cannot take it: the flip path.
            let mut inherited = precise(target);
            inherited.begin(Target::Reversed, reversal, Default::default());
            inherited.inherit_viewports();
            inherited.bind_pipeline(Some(derived_pipeline()));
            let mut sink = Recorded::default();
            inherited.before_draw(&mut sink);
            assert_eq!(inherited.path(), DrawPath::Flip);
        }
    }

    #[test]
    fn a_push_for_another_pipeline_is_never_overwritten_by_the_carrier() {
        // Bound: a pipeline whose stage derives its range (revz's layout 9). The application
        // then pushes 128 bytes with a layout of other ranges (no revz layout of its own), for
        // the pipeline it binds next: those bytes may cover the carrier's.
        let mut state = precise(RewriteTarget::Infinite);
        let reversal = state.reversal();
        state.begin(Target::Reversed, reversal, Default::default());
        state.bind_pipeline(Some(derived_pipeline()));
        let mut sink = Recorded::default();
        state.settle(&mut sink);
        assert_eq!(sink.pushed.len(), 1, "the selector, with revz's layout");
        state.note_push_pusher(vk::PipelineLayout::null());
        let (_, folded) = state.push_constants(layout(), OTHER_STAGES, 0, &[0; 128]);
        assert!(
            folded.is_none(),
            "not extended with this pipeline's carrier"
        );
        state.settle(&mut sink);
        assert_eq!(
            sink.pushed.len(),
            1,
            "nothing pushed over the application's bytes"
        );
        // The application binds again (its next pipeline, here the same): the carrier its
        // push may have overwritten goes down again.
        state.bind_pipeline(Some(derived_pipeline()));
        state.settle(&mut sink);
        assert_eq!(sink.pushed.len(), 2);
        assert_eq!(
            sink.pushed.last().map(|p| p.0),
            Some(vk::PipelineLayout::from_raw(9))
        );
        assert_eq!(state.path(), DrawPath::Precise);
        // A push with a layout of the pipeline's own ranges is compatible: folded as before.
        state.note_push_pusher(vk::PipelineLayout::from_raw(9));
        state.push_constants(vk::PipelineLayout::from_raw(30), OTHER_STAGES, 0, &[0; 16]);
        state.settle(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
    }

    #[test]
    fn a_dynamic_minus_one_to_one_convention_is_converted_by_the_stage_and_set_to_zero_to_one() {
        // Zink: the clip convention is dynamic and set [-1, 1] before each draw.
        let pipeline = Arc::new(PipelineDepth {
            app_dynamic: States::CLIP_CONTROL,
            ..(*derived_pipeline()).clone()
        });
        let mut state = precise(RewriteTarget::Infinite);
        let reversal = state.reversal();
        state.begin(Target::Reversed, reversal, Default::default());
        state.bind_pipeline(Some(pipeline));
        state.set_clip_negative_one_to_one(true);
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        let carrier = Carrier::bytes(&[0.0, 0.0, 0.0, 4.0]).to_vec();
        assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&carrier));
        assert_eq!(sink.clip_conventions, vec![false]);
        // Into a native attachment: the application's [-1, 1] and the shader's own z.
        state.set_target(Target::Native);
        state.before_draw(&mut sink);
        assert_eq!(sink.clip_conventions, vec![false, true]);
        let flip = Carrier::bytes(&FLIP_CARRIER).to_vec();
        assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&flip));
        // [0, 1] set by the application: selector 2, nothing converted.
        state.set_target(Target::Reversed);
        state.set_clip_negative_one_to_one(false);
        state.before_draw(&mut sink);
        let carrier = Carrier::bytes(&[0.0, 0.0, 0.0, 2.0]).to_vec();
        assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&carrier));
        assert_eq!(sink.clip_conventions, vec![false, true, false]);
    }

    #[test]
    fn a_recording_looks_each_pipeline_up_once_until_the_device_destroys_one() {
        let mut state = begun(Target::Reversed);
        let depth = |raw: u64, compare_op: vk::CompareOp| {
            Arc::new(PipelineDepth {
                handle: vk::Pipeline::from_raw(raw),
                compare_op,
                ..(*static_pipeline()).clone()
            })
        };
        let lookups = std::cell::Cell::new(0);
        let bind = |state: &mut CommandState,
                    raw: u64,
                    generation: u64,
                    found: Option<Arc<PipelineDepth>>| {
            state.bind_pipeline_handle(vk::Pipeline::from_raw(raw), generation, || {
                lookups.set(lookups.get() + 1);
                found
            });
            state.pipeline().map(|p| (p.handle.as_raw(), p.compare_op))
        };
        let (less, equal) = (vk::CompareOp::LESS, vk::CompareOp::EQUAL);
        assert_eq!(
            bind(&mut state, 1, 0, Some(depth(1, less))),
            Some((1, less))
        );
        assert_eq!(bind(&mut state, 2, 0, None), None, "untracked");
        assert_eq!(lookups.get(), 2);
        // Bound again: known, whatever a lookup would say.
        assert_eq!(bind(&mut state, 1, 0, None), Some((1, less)));
        assert_eq!(bind(&mut state, 2, 0, Some(depth(2, less))), None);
        assert_eq!(lookups.get(), 2);
        // A pipeline destroyed on the device (and its handle reused): looked up again.
        assert_eq!(
            bind(&mut state, 1, 1, Some(depth(1, equal))),
            Some((1, equal))
        );
        assert_eq!(lookups.get(), 3);
        // More pipelines than slots: each bind still gets its own.
        for raw in 10..20 {
            assert_eq!(
                bind(&mut state, raw, 1, Some(depth(raw, less))),
                Some((raw, less))
            );
        }
        assert_eq!(
            bind(&mut state, 1, 1, Some(depth(1, equal))),
            Some((1, equal))
        );
        // The settle after a bind sends the newly bound pipeline's flipped compare op.
        let mut sink = Recorded::default();
        state.settle(&mut sink);
        assert_eq!(sink.compare_ops.last(), Some(&vk::CompareOp::EQUAL));
    }

    #[test]
    fn a_projection_takes_the_precise_path_through_the_carrier_pushed_once_per_camera() {
        let mut state = precise(RewriteTarget::Complementary);
        state.begin(
            Target::Reversed,
            Reversal::Complementary,
            Default::default(),
        );
        state.bind_pipeline(Some(projection_pipeline()));
        let data = perspective_bytes();
        // Pushed with other stages than the carrier's range: the draw sends the carrier.
        let (outcome, folded) = state.push_constants(layout(), OTHER_STAGES, 0, &data);
        assert!(matches!(outcome, Some(Outcome::Rewritten { .. })));
        assert!(folded.is_none());
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        // The application's bytes are never re-sent; only the carrier goes down, read by the
        // application's pipeline's own (rewritten) vertex stage: nothing else is bound.
        assert_eq!(sink.pushes, vec![(112, 16)]);
        assert!(sink.binds.is_empty());
        // [0, 1] -> [1 - 1, 1 - 0]: the rewritten store already reverses.
        assert_eq!(sink.viewports, vec![(0, vec![(0.0, 1.0)])]);
        assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER]);

        // The next object's matrix of the same camera: nothing to send at its draw.
        state.push_constants(layout(), OTHER_STAGES, 0, &data);
        state.before_draw(&mut sink);
        assert_eq!(sink.pushes.len(), 1);
        assert_eq!(sink.viewports.len(), 1);
        // A push with another layout may have disturbed the carrier: it goes down again.
        state.push_constants(vk::PipelineLayout::from_raw(4), OTHER_STAGES, 0, &data);
        state.before_draw(&mut sink);
        assert_eq!(sink.pushes, vec![(112, 16), (112, 16)]);
    }

    #[test]
    fn a_push_of_the_carriers_stages_carries_it_when_it_changes() {
        let mut state = precise(RewriteTarget::Infinite);
        state.begin(
            Target::Reversed,
            Reversal::Infinite { near_over_far: 0.0 },
            Default::default(),
        );
        state.bind_pipeline(Some(projection_pipeline()));
        let data = perspective_bytes();
        let (outcome, folded) =
            state.push_constants(layout(), vk::ShaderStageFlags::VERTEX, 0, &data);
        let Some(Outcome::Rewritten { carrier, .. }) = outcome else {
            panic!("{outcome:?}");
        };
        let folded = folded.expect("the carrier goes with the push");
        assert_eq!((folded.offset, folded.size), (0, 128));
        let mut out = [0xAA; crate::precise::PUSH_CONSTANT_BYTES];
        let bytes = state.folded_bytes(&folded, &mut out);
        assert_eq!(bytes.len(), 128);
        assert_eq!(bytes[..64], data[..]);
        assert_eq!(bytes[64..112], [0; 48], "bytes never pushed");
        assert_eq!(bytes[112..128], Carrier::bytes(&carrier));
        // The draw has nothing to push; the same camera's next matrix goes down as it is.
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        assert!(sink.pushes.is_empty());
        let (_, again) = state.push_constants(layout(), vk::ShaderStageFlags::VERTEX, 0, &data);
        assert!(again.is_none());
        // Not sent extended (a caller that could not): the draw sends it.
        let (_, other) = state.push_constants(
            vk::PipelineLayout::from_raw(4),
            vk::ShaderStageFlags::VERTEX,
            0,
            &data,
        );
        assert!(other.is_some());
        state.unfold();
        state.before_draw(&mut sink);
        assert_eq!(sink.pushes, vec![(112, 16)]);
    }

    #[test]
    fn without_a_push_layout_the_application_pipeline_draws_with_the_flip_path() {
        let mut state = precise(RewriteTarget::Complementary);
        state.begin(
            Target::Reversed,
            Reversal::Complementary,
            Default::default(),
        );
        state.bind_pipeline(Some(projection_pipeline()));
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip);
        assert!(sink.pushes.is_empty());
        assert!(
            sink.binds.is_empty(),
            "the application's pipeline stays bound"
        );
    }

    #[test]
    fn viewports_go_down_before_secondaries_run_for_the_flip_path_they_inherit() {
        let mut state = precise(RewriteTarget::Complementary);
        state.begin(Target::None, Reversal::Complementary, Default::default());
        let mut sink = Recorded::default();
        // Nothing set: nothing to send.
        state.flush_viewports_for_secondaries(&mut sink);
        assert_eq!(sink, Recorded::default());
        // Set before a render pass of secondaries into a reversed attachment.
        state.set_viewports(0, &[viewport(0.0, 1.0)]);
        state.set_compare_op(vk::CompareOp::LESS);
        state.set_target(Target::Reversed);
        state.flush_viewports_for_secondaries(&mut sink);
        assert_eq!(
            sink,
            Recorded {
                viewports: vec![(0, vec![(1.0, 0.0)])],
                ..Default::default()
            },
            "only the viewports, flipped: nothing else is inherited"
        );
        state.set_secondary_contents(true);
        assert!(!state.records_inline());
        // Into a native attachment: the application's values.
        state.set_target(Target::Native);
        state.flush_viewports_for_secondaries(&mut sink);
        assert_eq!(sink.viewports.last(), Some(&(0, vec![(0.0, 1.0)])));
    }

    #[test]
    fn a_secondary_inheriting_viewports_takes_the_flip_path_even_with_a_pushed_projection() {
        let mut state = precise(RewriteTarget::Complementary);
        state.begin(
            Target::Reversed,
            Reversal::Complementary,
            Default::default(),
        );
        state.inherit_viewports();
        state.bind_pipeline(Some(projection_pipeline()));
        state.push_constants(layout(), OTHER_STAGES, 0, &perspective_bytes());
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip);
        // The variant is drawn with the flip carrier: the shader's own z.
        assert_eq!(sink.pushes, vec![(112, 16)]);
        // A new recording of the same command buffer forgets it.
        state.begin(
            Target::Reversed,
            Reversal::Complementary,
            Default::default(),
        );
        state.bind_pipeline(Some(projection_pipeline()));
        state.push_constants(layout(), OTHER_STAGES, 0, &perspective_bytes());
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
    }

    #[test]
    fn draws_without_a_push_constant_projection_take_the_flip_path() {
        let mut state = precise(RewriteTarget::Complementary);
        state.begin(
            Target::Reversed,
            Reversal::Complementary,
            Default::default(),
        );
        state.bind_pipeline(Some(static_pipeline()));
        assert_eq!(
            state
                .push_constants(
                    layout(),
                    vk::ShaderStageFlags::VERTEX,
                    0,
                    &perspective_bytes()
                )
                .0,
            None,
            "not this pipeline's projection"
        );
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip);
        assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.0)])]);
    }

    #[test]
    fn a_projection_pushed_outside_the_render_pass_is_classified_at_the_draw() {
        let mut state = precise(RewriteTarget::Infinite);
        state.begin(
            Target::None,
            Reversal::Infinite { near_over_far: 0.0 },
            Default::default(),
        );
        state.bind_pipeline(Some(projection_pipeline()));
        state.push_constants(
            layout(),
            vk::ShaderStageFlags::VERTEX,
            0,
            &perspective_bytes(),
        );
        state.set_target(Target::Reversed);
        let mut sink = Recorded::default();
        let outcome = state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        assert_eq!(sink.pushes, vec![(112, 16)]);
        // Infinite mode learned n / f = 0.01 from it, for the flip path's state.
        let Some(Outcome::Rewritten { near_over_far, .. }) = outcome else {
            panic!("{outcome:?}");
        };
        assert!((near_over_far - 0.01).abs() < 1e-6);
        assert_eq!(state.reversal(), Reversal::Infinite { near_over_far });

        // A flip-path pipeline in the same pass: nothing pushed, and its viewport maps
        // standard depth to n / w: [0, 1] -> [1, n / f].
        state.bind_pipeline(Some(static_pipeline()));
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip);
        assert_eq!(sink.pushes.len(), 1);
        assert_eq!(
            sink.viewports.last(),
            Some(&(0, vec![(1.0, near_over_far)]))
        );

        // Native attachments get the carrier that keeps the shader's own z, and no flipped
        // state.
        state.bind_pipeline(Some(projection_pipeline()));
        state.set_target(Target::Native);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Native);
        assert_eq!(sink.pushes, vec![(112, 16), (112, 16)]);
        assert_eq!(sink.viewports.last(), Some(&(0, vec![(0.0, 1.0)])));
        assert_eq!(sink.compare_ops.last(), Some(&vk::CompareOp::LESS));
    }

    #[test]
    fn rebinding_pipelines_with_the_same_state_sends_nothing_again() {
        let mut state = begun(Target::Reversed);
        let mut sink = Recorded::default();
        for _ in 0..3 {
            state.bind_pipeline(Some(static_pipeline()));
            state.before_draw(&mut sink);
        }
        assert_eq!(sink.viewports.len(), 1);
        assert_eq!(sink.compare_ops.len(), 1);
        assert_eq!(sink.biases.len(), 1);

        // A pipeline that keeps the compare op static overwrites it: after it, it is sent again.
        state.bind_pipeline(Some(Arc::new(PipelineDepth {
            injected: States::VIEWPORT | States::BIAS,
            ..(*static_pipeline()).clone()
        })));
        state.before_draw(&mut sink);
        state.bind_pipeline(Some(static_pipeline()));
        state.before_draw(&mut sink);
        assert_eq!(sink.viewports.len(), 1);
        assert_eq!(sink.compare_ops.len(), 2);

        // After secondaries ran, everything is sent again.
        state.invalidate();
        state.before_draw(&mut sink);
        assert_eq!(sink.viewports.len(), 2);
        assert_eq!(sink.compare_ops.len(), 3);
    }
}
