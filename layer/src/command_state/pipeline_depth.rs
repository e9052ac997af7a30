//! What revz knows of a graphics pipeline for draw time: the states it sets statically and the
//! ones revz made dynamic, its static values, where its projection is, and its variants.

use ash::vk;

use crate::conv::DepthBias;
use crate::precise::{Carrier, ProjectionUse};
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
    /// `depthClampEnable`, set with `vkCmdSetDepthClampEnableEXT`: only followed, never sent
    /// (infinite mode's precise path cannot clamp at the far plane: such draws take the flip
    /// path, `CommandState::clamps_at_far`).
    pub const DEPTH_CLAMP: States = States(64);
    /// `VK_EXT_depth_clamp_control`'s clamp range, set with `vkCmdSetDepthClampRangeEXT`: a
    /// user-defined range is a pair of depth values, mapped like the depth bounds.
    pub const CLAMP_RANGE: States = States(128);
    pub const ALL: States = States(255);
    /// The states whose values a bind may change without a full settle
    /// ([`PipelineDepth::values_apart`]).
    pub const VALUES: States = States(4 | 8 | 16 | 128);

    pub fn contains(self, other: States) -> bool {
        self.0 & other.0 == other.0
    }

    pub fn intersects(self, other: States) -> bool {
        self.0 & other.0 != 0
    }

    /// These states but `other`.
    #[must_use]
    pub fn without(self, other: States) -> States {
        States(self.0 & !other.0)
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
            vk::DynamicState::DEPTH_CLAMP_ENABLE_EXT => States::DEPTH_CLAMP,
            crate::vk_ext::DYNAMIC_STATE_DEPTH_CLAMP_RANGE => States::CLAMP_RANGE,
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

/// How a pipeline clips depth (`VK_EXT_depth_clip_enable`): with its clamp, whether an
/// infinite-mode draw clamps at a far plane the precise path removed
/// (`CommandState::clamps_at_far`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DepthClip {
    /// No `VkPipelineRasterizationDepthClipStateCreateInfoEXT`: depth is clipped exactly where
    /// it is not clamped (the spec's default).
    #[default]
    Implied,
    /// Its `depthClipEnable`, static.
    Static(bool),
    /// `VK_DYNAMIC_STATE_DEPTH_CLIP_ENABLE_EXT`: `vkCmdSetDepthClipEnableEXT`'s value.
    Dynamic,
}

impl DepthClip {
    /// Whether depth is clipped, where it is clamped or not (`clamp`) and the application last
    /// set dynamic clipping to `dynamic` (`None`: never; the spec's default applies then).
    pub fn clips(self, clamp: bool, dynamic: Option<bool>) -> bool {
        match self {
            DepthClip::Implied => !clamp,
            DepthClip::Static(clips) => clips,
            DepthClip::Dynamic => dynamic.unwrap_or(!clamp),
        }
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
    /// The user-defined depth clamp range of its `VkPipelineViewportDepthClampControlCreateInfoEXT`
    /// (`VK_EXT_depth_clamp_control`), where revz made it dynamic ([`States::CLAMP_RANGE`]).
    pub clamp_range: (f32, f32),
    /// Its static `depthClampEnable` (read where the application did not make the clamp
    /// dynamic, [`States::DEPTH_CLAMP`]).
    pub static_clamp: bool,
    /// How it clips depth.
    pub depth_clip: DepthClip,
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
    /// For a pipeline whose fragment stage reads depth through input attachments
    /// (`crate::shader::input_depth`): the pipeline with those reads converted and nothing
    /// else changed, bound for draws whose subpass reads reversed depth as an input but does
    /// not draw into a reversed depth attachment (the reversed variants convert the reads
    /// too); and the same for the promoted twin of its render pass.
    pub input_variant: Option<vk::Pipeline>,
    pub promoted_input_variant: Option<vk::Pipeline>,
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
    /// The layout has no room for the carrier: the pipeline keeps the application's stage,
    /// and its reversed variants (`reversed_variant`, `promoted_reversed_variant`) have the
    /// stage that derives its range with the carrier baked in (complementary depth), bound
    /// for its precise-path draws only; nothing is pushed for it (issue #41).
    pub baked: bool,
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
    /// `promoted` attachment, in a subpass whose input attachments read reversed depth
    /// (`reversed_inputs`) or not (`None`: the pipeline itself).
    pub fn variant_for(
        &self,
        reversed: bool,
        promoted: bool,
        reversed_inputs: bool,
    ) -> Option<vk::Pipeline> {
        match (promoted && self.promotable, reversed, reversed_inputs) {
            (false, false, false) => None,
            (false, false, true) => self.input_variant,
            (false, true, _) => self.reversed_variant,
            (true, false, false) => self.promoted_variant,
            (true, false, true) => self.promoted_input_variant.or(self.promoted_variant),
            (true, true, _) => self.promoted_reversed_variant.or(self.promoted_variant),
        }
    }

    /// Whether a settle after binding this pipeline in `other`'s place, nothing else changed,
    /// sends what it sent for `other`: [`Self::values_apart`] of nothing.
    pub fn settles_like(&self, other: &PipelineDepth) -> bool {
        self.values_apart(other) == Some(States::NONE)
    }

    /// What a settle after binding this pipeline in `other`'s place, nothing else changed,
    /// sends that it did not send for `other`: `Some` of the value states (compare op, bias,
    /// bounds, clamp range) revz made dynamic in either whose static values differ or that
    /// only one makes dynamic, where the two agree in everything else a settle reads: the same
    /// states dynamic for the application, the same viewports made dynamic or not (and the
    /// same ones where revz made them dynamic), and the same facts for the precise path
    /// (projection, carrier, derived range, push layout). `None`: a full settle.
    /// A bind between two such pipelines re-evaluates only those states (issue #42: a LESS
    /// and a LESS_OR_EQUAL pipeline, the commonest pair, differ in nothing else). Compared
    /// exactly: floats by bits where revz compares what it sent by bits, and a NaN always
    /// differs (the state is evaluated again: the safe answer). Not compared: the variants,
    /// which the bind itself chooses.
    pub fn values_apart(&self, other: &PipelineDepth) -> Option<States> {
        if std::ptr::eq(self, other) {
            return Some(States::NONE);
        }
        // Which of the value states revz made dynamic may differ too: one made dynamic in one
        // pipeline only is evaluated again (sent where it is dynamic now; where it is static
        // now, the bind sets it and what was sent of it is forgotten). A pipeline with depth
        // bias and one without, the commonest such pair.
        let injected = self.injected & other.injected;
        let injected_apart = States(self.injected.0 ^ other.injected.0);
        fn viewport_bits(p: &PipelineDepth) -> impl Iterator<Item = [u32; 6]> + '_ {
            p.viewports
                .iter()
                .map(|v| [v.x, v.y, v.width, v.height, v.min_depth, v.max_depth].map(f32::to_bits))
        }
        let alike = self.app_dynamic == other.app_dynamic
            && self.static_clamp == other.static_clamp
            && self.depth_clip == other.depth_clip
            && injected_apart.without(States::VALUES).is_empty()
            && self.unreversed_fragment == other.unreversed_fragment
            && self.projection == other.projection
            && self.position_store == other.position_store
            && self.derived_range == other.derived_range
            && self.baked == other.baked
            && self.layout == other.layout
            && (!injected.contains(States::VIEWPORT)
                || (self.viewports.len() == other.viewports.len()
                    && viewport_bits(self).eq(viewport_bits(other))));
        if !alike {
            return None;
        }
        // Two floats that certainly settle alike: the same bits, no NaN.
        let same = |(a, b): (f32, f32), (c, d): (f32, f32)| {
            (a.to_bits(), b.to_bits()) == (c.to_bits(), d.to_bits()) && !a.is_nan() && !b.is_nan()
        };
        let mut apart = States::NONE;
        if self.compare_op != other.compare_op {
            apart |= States::COMPARE_OP;
        }
        if self.bias != other.bias {
            apart |= States::BIAS;
        }
        if !same(self.bounds, other.bounds) {
            apart |= States::BOUNDS;
        }
        if !same(self.clamp_range, other.clamp_range) {
            apart |= States::CLAMP_RANGE;
        }
        // Static values of states the application sets (or revz leaves static in both) are
        // not sent.
        Some((apart & injected & States::VALUES) | injected_apart)
    }

    /// The pipelines revz made for this one (to destroy with it).
    pub fn variants(&self) -> impl Iterator<Item = vk::Pipeline> {
        [
            self.reversed_variant,
            self.promoted_variant,
            self.promoted_reversed_variant,
            self.input_variant,
            self.promoted_input_variant,
        ]
        .into_iter()
        .flatten()
    }
}
