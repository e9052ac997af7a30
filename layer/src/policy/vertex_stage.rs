//! Whether a pipeline's draws can take the precise path: its vertex stage stores reversed
//! depth itself (`crate::shader::position_store`), on the line of a projection found in its
//! push constants, or of one it fits from the matrix it loads from a buffer
//! (`crate::shader::derived_range`). Otherwise its draws take the flip path, for the reason
//! returned (logged, and shown in the depth profile).
//!
//! The facts come from `vkCreateShaderModule` (each module's analysis and `Position` rewrite,
//! or those of inline code, made once per distinct code) and `vkCreateGraphicsPipelines` (the
//! stages, the clip convention, the layout); `crate::hooks::pipeline::plan` gathers them.
//! Which `Position` rewrite a module gets ([`position_store`]) is decided here too, and which
//! modules are analysed at all ([`analyses_fragment_module`], [`analyses_vertex_module`]),
//! and why a pipeline whose rewritten stage could not be made takes the flip path after all
//! ([`unmade_stage_flip`]). The facts revz may lack of a stage, and why its draws then take
//! the flip path, are here too ([`MissingFact`], [`entry_point_analysis`]).

use ash::vk;
use revz_math::DepthConvention;
use revz_math::Target as RewriteTarget;

use crate::objects::ModuleAnalysis;
use crate::precise::ProjectionUse;
use crate::shader::analysis::{Analysis, ProjectionSlot};
use crate::shader::derived_range::MatrixSource;
use crate::shader::position_store::Unsupported;

/// Whether `vkCreateShaderModule` looks at a module's fragment entry points (whether one
/// computes with depth, `crate::shader::fragment_depth`): only where revz acts on the
/// device's depth (`active`).
#[must_use]
pub fn analyses_fragment_module(active: bool) -> bool {
    active
}

/// Whether `vkCreateShaderModule` analyses a module's pre-rasterization stage (its projection
/// and `Position` rewrite): only where the mode rewrites projections (`mode_rewrites`) and the
/// module declares an entry point of a stage that can be the last before rasterization, whose
/// `Position` revz rewrites: vertex, tessellation evaluation, geometry or mesh
/// (`declares_position_stage`, scanned only then). Fragment and compute modules with push
/// constants are not parsed.
#[must_use]
pub fn analyses_vertex_module(
    mode_rewrites: bool,
    declares_position_stage: impl FnOnce() -> bool,
) -> bool {
    mode_rewrites && declares_position_stage()
}

/// Whether a pipeline is a candidate for the precise path at all: the mode rewrites
/// projections, the pipeline renders depth, and its create info defines the
/// pre-rasterization shaders (a library of other subsets has no vertex stage to rewrite).
#[must_use]
pub fn precise_candidate(mode_rewrites: bool, renders_depth: bool, defines_shaders: bool) -> bool {
    mode_rewrites && renders_depth && defines_shaders
}

/// Whether a pipeline clamps depth (`depthClampEnable` of its rasterization state) without
/// clipping it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthClamp {
    /// Static, off (or no rasterization state).
    Off,
    /// Static, on, and depth clipping off with it (the spec's default where no
    /// `VkPipelineRasterizationDepthClipStateCreateInfoEXT` says otherwise).
    On,
    /// Static, on, with depth clipping kept on (`VK_EXT_depth_clip_enable`'s
    /// `depthClipEnable = VK_TRUE`): what D3D translators (DXVK, vkd3d) set for every pipeline,
    /// as Direct3D clamps depth to the viewport range after clipping. Clipped primitives'
    /// depths lie inside the range already, so the clamp changes none of them.
    OnClipped,
    /// Dynamic (`VK_DYNAMIC_STATE_DEPTH_CLAMP_ENABLE_EXT`), or on with dynamic depth clipping
    /// (`VK_DYNAMIC_STATE_DEPTH_CLIP_ENABLE_EXT`): either, per draw.
    Dynamic,
}

/// Why a pipeline that could take the precise path takes the flip path because it clamps
/// depth; `None`: it keeps the precise path. Infinite mode's precise path stores n/w with the
/// far plane removed, so a clamped fragment beyond the far plane is stored below the far
/// plane's n/f instead of at it: the order and values of what the application clamps to its
/// far plane would change. The flip path maps the clamped standard depth, exactly. The
/// complementary precise path clamps at the far plane's 0, as the application's range
/// mirrored, and keeps it.
///
/// A clamp with depth clipping kept on keeps the precise path: clipping removes what lies
/// beyond the planes before the clamp, and infinite mode's stored n/w lies in (0, 1] for
/// everything in front of the near plane, inside the (mirrored) viewport range the clamp
/// clamps to (measured: `vkd3d-gears`, whose every pipeline clamps with clipping on, took the
/// flip path before).
///
/// A dynamic clamp keeps the precise path here: Zink makes it dynamic in every pipeline
/// (extended dynamic state 3) and almost never enables it; the draws recorded with it enabled
/// and clipping off take the flip path, decided per draw (`crate::command_state::CommandState`'s
/// `clamps_at_far`).
#[must_use]
pub fn depth_clamp_flip(target: RewriteTarget, clamp: DepthClamp) -> Option<&'static str> {
    match (target, clamp) {
        (RewriteTarget::Infinite, DepthClamp::On) => Some(
            "it clamps depth (depthClampEnable), which infinite mode's precise path cannot \
             clamp at the far plane",
        ),
        _ => None,
    }
}

/// Why a precise pipeline's draws take the flip path after all, where its rewritten vertex
/// stage could not be made (`made`: its module was created); `None`: it was, and the pipeline
/// keeps the precise path. Without the stage nothing of the precise path stays: the hook drops
/// the pipeline's projection, derived range and store with it, as the application's stage
/// stores its own depth.
#[must_use]
pub fn unmade_stage_flip(made: bool) -> Option<&'static str> {
    (!made).then_some("its rewritten vertex stage could not be made")
}

/// Which `Position` rewrite a vertex module gets (in a mode with the precise path, where its
/// analysis could be read).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PositionStore {
    /// An entry point has its projection in push constants: the stage stores the carrier's
    /// depth (`crate::shader::position_store::rewrite_position_store`).
    Carrier,
    /// None has: the stage derives its range from the matrix it loads
    /// (`crate::shader::position_store::rewrite_position_store_deriving`).
    Deriving,
}

/// The `Position` rewrite of a module whose entry points were analyzed as `entry_points`.
#[must_use]
pub fn position_store<'a>(entry_points: impl IntoIterator<Item = &'a Analysis>) -> PositionStore {
    if entry_points
        .into_iter()
        .any(|analysis| matches!(analysis, Analysis::Projection(_)))
    {
        PositionStore::Carrier
    } else {
        PositionStore::Deriving
    }
}

/// Which `Position` rewrite a vertex module gets ([`position_store`] of its entry points), and
/// the carrier's offset it stores through; `None`: none, without the precise path
/// (`carrier_offset`, [`super::DevicePolicy::carrier_offset`]). A module naga could not read
/// (`entry_points`: `None`) gets the deriving one, which reads the words itself.
#[must_use]
pub fn module_position_store<'a>(
    carrier_offset: Option<u32>,
    entry_points: Option<impl IntoIterator<Item = &'a Analysis>>,
) -> Option<(u32, PositionStore)> {
    let offset = carrier_offset?;
    Some((
        offset,
        entry_points.map_or(PositionStore::Deriving, position_store),
    ))
}

/// The last pre-rasterization stage of a pipeline: the one whose `Position` is rasterized,
/// and which the precise path rewrites.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LastStage {
    Vertex,
    TessellationEvaluation,
    Geometry,
    /// A mesh shader (`VK_EXT_mesh_shader`): it writes a per-vertex array of positions, each
    /// rewritten where it is stored (`crate::shader::position_store`).
    Mesh,
}

impl LastStage {
    /// The stage whose `Position` store the precise path rewrites among a pipeline's `stages`:
    /// the last pre-rasterization stage ([`Self::of`]), but the stage before stages that only
    /// carry the positions they receive on (`carries_positions_on`, asked of a geometry stage,
    /// then of the tessellation control and evaluation stages together): a geometry stage
    /// that stores `gl_in[i].gl_Position` as it is and reads no z of it otherwise (a wireframe
    /// overlay, a layered pass), tessellation stages that copy the positions and interpolate
    /// them (affine combinations: `crate::shader::tessellation_positions`). Copies and affine
    /// combinations keep the line `z = k w + B` the stage before stores on, so that stage's
    /// rewrite reaches the rasterizer unchanged.
    #[must_use]
    pub fn rewritten(
        stages: &[vk::ShaderStageFlags],
        carries_positions_on: impl Fn(vk::ShaderStageFlags) -> bool,
    ) -> Option<LastStage> {
        use vk::ShaderStageFlags as S;
        let mut kept: Vec<vk::ShaderStageFlags> = stages.to_vec();
        if LastStage::of(kept.iter().copied()) == Some(LastStage::Geometry)
            && carries_positions_on(S::GEOMETRY)
        {
            kept.retain(|&stage| stage != S::GEOMETRY);
        }
        if LastStage::of(kept.iter().copied()) == Some(LastStage::TessellationEvaluation)
            && kept.contains(&S::TESSELLATION_CONTROL)
            && carries_positions_on(S::TESSELLATION_CONTROL)
            && carries_positions_on(S::TESSELLATION_EVALUATION)
        {
            kept.retain(|&stage| {
                stage != S::TESSELLATION_CONTROL && stage != S::TESSELLATION_EVALUATION
            });
        }
        LastStage::of(kept)
    }

    /// The last pre-rasterization stage among a pipeline's `stages` (geometry, else
    /// tessellation evaluation, else mesh or vertex); `None` where it has none of them.
    #[must_use]
    pub fn of(stages: impl IntoIterator<Item = vk::ShaderStageFlags>) -> Option<LastStage> {
        let all = stages
            .into_iter()
            .fold(vk::ShaderStageFlags::empty(), |all, stage| all | stage);
        [
            (vk::ShaderStageFlags::GEOMETRY, LastStage::Geometry),
            (
                vk::ShaderStageFlags::TESSELLATION_EVALUATION,
                LastStage::TessellationEvaluation,
            ),
            (vk::ShaderStageFlags::MESH_EXT, LastStage::Mesh),
            (vk::ShaderStageFlags::VERTEX, LastStage::Vertex),
        ]
        .into_iter()
        .find(|(flag, _)| all.contains(*flag))
        .map(|(_, stage)| stage)
    }

    /// The stage's name, as logs say "its ... stage".
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            LastStage::Vertex => "vertex",
            LastStage::TessellationEvaluation => "tessellation evaluation",
            LastStage::Geometry => "geometry",
            LastStage::Mesh => "mesh",
        }
    }

    /// The stage's flag.
    #[must_use]
    pub fn flag(self) -> vk::ShaderStageFlags {
        match self {
            LastStage::Vertex => vk::ShaderStageFlags::VERTEX,
            LastStage::TessellationEvaluation => vk::ShaderStageFlags::TESSELLATION_EVALUATION,
            LastStage::Geometry => vk::ShaderStageFlags::GEOMETRY,
            LastStage::Mesh => vk::ShaderStageFlags::MESH_EXT,
        }
    }
}

/// What revz knows of a candidate pipeline's last pre-rasterization stage (its vertex stage,
/// or the tessellation evaluation or geometry stage after it).
#[derive(Clone, Copy, Debug)]
pub struct VertexStageFacts<'a> {
    /// Its shader code is given (not only module identifiers or a pipeline binary).
    pub code_given: bool,
    /// Its last pre-rasterization stage, if it has one.
    pub last_stage: Option<LastStage>,
    /// revz's carrier in its layout is visible to that stage (the layout's range that holds
    /// the carrier names the stage).
    pub carrier_reaches_stage: bool,
    /// The analysis of its vertex entry point: `Ok(None)` where the module holds no entry
    /// point analyzed (a module without push constants is not parsed); `Err` where revz could
    /// not get one (unknown module, no code, naga cannot read it, no entry point name).
    pub analysis: Result<Option<&'a Analysis>, &'static str>,
    /// Its pipeline layout's push-constant ranges, if revz knows the layout.
    pub ranges: Option<&'a [vk::PushConstantRange]>,
    /// Its clip depth convention; `None` where dynamic
    /// (`vkCmdSetDepthClipNegativeOneToOneEXT`, known per draw).
    pub convention: Option<DepthConvention>,
    /// Its layout has room for revz's carrier.
    pub carrier_room: bool,
    /// Where its layout has no room: the deriving rewrite of its stage with the carrier baked
    /// in (`crate::shader::position_store::CarrierRead::Baked`), which its reversed variants
    /// get, and where that stage's matrix comes from; or why there is none. `None` where it
    /// was not made (the layout has room, or the pipeline is a library or links libraries,
    /// whose variants link stages revz cannot replace).
    pub baked: Option<Result<MatrixSource, &'a str>>,
    /// Its vertex module's `Position` rewrite: where its stage derives the range from (`None`:
    /// it does not), or why it has none.
    pub rewrite: Result<Option<MatrixSource>, Missing>,
    /// Where the matrix a deriving rewrite fits lies in the push constants, where the stage
    /// loads it whole from a member of its block (`None` otherwise): a stage naga does not
    /// read (tessellation evaluation, geometry, mesh) gets its projection classified on the
    /// CPU from it too, the fit kept for the matrices that do not classify.
    pub derived_slot: Option<ProjectionSlot>,
    /// The rewritten stage projects the previous stage's `Position` (`gl_in[i].gl_Position`),
    /// and whether that stage stores it with w = 1: `None` where the rewrite needs nothing of
    /// the stage before.
    pub input_unit_w: Option<bool>,
}

/// A fact revz lacks of a candidate pipeline's vertex stage while it gathers
/// [`VertexStageFacts`]: each is why its draws take the flip path where
/// [`VertexStageFacts::decide`] gets to it ([`MissingFact::reason`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MissingFact {
    /// Its vertex module is not one revz saw created: no analysis.
    UnknownModule,
    /// revz holds no `Position` rewrite of its vertex module.
    ModuleWithoutRewrite,
    /// revz holds no `Position` rewrite of its inline code.
    InlineWithoutRewrite,
    /// Its vertex stage has neither a module nor inline code: no analysis, no rewrite.
    NoModule,
    /// It has no vertex stage: no analysis, no rewrite.
    NoVertexStage,
    /// naga cannot read its vertex module.
    UnreadableModule,
    /// Its vertex stage names no entry point.
    NoEntryPointName,
    /// The policy found every fact, yet the layout's carrier, the rewrite or the stage is
    /// missing (the facts disagree: never expected).
    Incomplete,
}

impl MissingFact {
    /// Why a pipeline lacking this fact takes the flip path, as logged and in the profile.
    #[must_use]
    pub fn reason(self) -> &'static str {
        match self {
            MissingFact::UnknownModule => "its vertex module is unknown",
            MissingFact::ModuleWithoutRewrite => "its vertex module has no Position rewrite",
            MissingFact::InlineWithoutRewrite => "its vertex shader has no rewrite",
            MissingFact::NoModule => "its vertex shader has no module",
            MissingFact::NoVertexStage => "it has no vertex stage",
            MissingFact::UnreadableModule => "naga cannot read its vertex module",
            MissingFact::NoEntryPointName => "no entry point name",
            MissingFact::Incomplete => "its vertex stage is incomplete",
        }
    }
}

/// The analysis of a vertex stage's entry point ([`VertexStageFacts::analysis`]) in its
/// module's (`module`: each vertex entry point's, or why naga could not read the module; `Err`:
/// why revz has none), by the entry point's name (`name`; `None`: the stage gives none).
/// `Ok(None)`: the module holds no analysis of that entry point.
pub fn entry_point_analysis<'a>(
    module: Result<&'a ModuleAnalysis, &'static str>,
    name: Option<&[u8]>,
) -> Result<Option<&'a Analysis>, &'static str> {
    match module? {
        Err(_) => Err(MissingFact::UnreadableModule.reason()),
        Ok(entries) => {
            let name = name.ok_or(MissingFact::NoEntryPointName.reason())?;
            Ok(entries
                .iter()
                .find(|(entry, _)| entry.as_bytes() == name)
                .map(|(_, analysis)| analysis))
        }
    }
}

/// Why a vertex module has no `Position` rewrite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Missing {
    /// revz holds none for it (the reason).
    NotMade(&'static str),
    /// The rewrite cannot be made.
    Unsupported(Unsupported),
}

/// Where a precise pipeline's vertex stage gets the range it stores depth with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexRange {
    /// The projection in its push constants, classified per push.
    pub projection: Option<ProjectionUse>,
    /// The matrix the stage loads and fits itself.
    pub derived: Option<MatrixSource>,
    /// The stage fits it with the carrier baked into the reversed variants' code: the
    /// layout has no room for the pushed one, and the application's pipeline keeps its own
    /// stage (issue #41).
    pub baked: bool,
}

impl VertexStageFacts<'_> {
    /// The precise path's range, or why the pipeline's draws take the flip path. The first
    /// reason in the order below is the one given.
    pub fn decide(&self) -> Result<VertexRange, String> {
        if !self.code_given {
            return Err("its code is not given (identifiers or binaries)".into());
        }
        let Some(stage) = self.last_stage else {
            return Err("it has no vertex stage".into());
        };
        // Where naga cannot read the module, no projection is read on the CPU, but the
        // deriving rewrite (word-level: it needs no naga) may still fit the matrix the stage
        // loads (Zink's module of glmark2's `terrain`); `unread` says why for the flip path
        // where it cannot.
        let (slot, unread) = match self.analysis {
            Ok(Some(Analysis::Projection(slot))) => (Some(slot), None),
            Ok(Some(Analysis::Unreadable(reason))) => (None, Some(reason.as_str())),
            // Not from push constants, or a module without push constants; the deriving
            // rewrite has its single vertex entry point.
            Ok(Some(_) | None) => (None, None),
            Err(reason) if reason == MissingFact::UnreadableModule.reason() => {
                (None, Some("its module as a whole"))
            }
            Err(reason) => return Err(reason.into()),
        };
        if !self.carrier_room {
            return self.decide_baked(stage);
        }
        let projection = match slot {
            Some(slot) => {
                let ranges = self.ranges.ok_or("its pipeline layout is unknown")?;
                let convention = self
                    .convention
                    .ok_or("its depth clip convention is dynamic")?;
                Some(ProjectionUse::new(slot, convention, ranges).map_err(|e| e.to_string())?)
            }
            // The derived range assumes [0, 1] clip depth: the [-1, 1] one would need the layer
            // to change the pipeline's clip convention.
            None if self.convention == Some(DepthConvention::NegativeOneToOne) => {
                return Err(
                    "its projection is not in push constants and its clip depth is \
                            [-1, 1] (VK_EXT_depth_clip_control)"
                        .into(),
                )
            }
            None => None,
        };
        if !self.carrier_reaches_stage {
            return Err(match stage {
                LastStage::Geometry => {
                    "revz's push constants do not reach its geometry stage (the layout's \
                     push-constant range that holds them does not name it)"
                }
                LastStage::Mesh => {
                    "revz's push constants do not reach its mesh stage (the layout's \
                     push-constant range that holds them does not name it)"
                }
                LastStage::TessellationEvaluation => {
                    "revz's push constants do not reach its tessellation evaluation stage \
                     (the layout's push-constant range that holds them does not name it)"
                }
                // A vertex stage in a layout whose carrier went into a mesh range (found in
                // review: a layout with a mesh range and no vertex range).
                LastStage::Vertex => {
                    "revz's push constants do not reach its vertex stage (the layout's \
                     push-constant range that holds them does not name it)"
                }
            }
            .into());
        }
        let derived = match self.rewrite {
            Ok(derived) => derived,
            Err(Missing::NotMade(reason)) => return Err(reason.into()),
            Err(Missing::Unsupported(reason)) if projection.is_some() => {
                return Err(format!("its Position store cannot be rewritten ({reason})"))
            }
            Err(Missing::Unsupported(reason)) if unread.is_some() => {
                return Err(format!(
                    "naga cannot read its vertex module ({}), and its vertex stage cannot \
                     derive its range ({reason})",
                    unread.unwrap_or_default()
                ))
            }
            Err(Missing::Unsupported(reason)) => {
                return Err(format!(
                    "its projection is not in push constants, and its vertex stage cannot \
                     derive its range ({reason})"
                ))
            }
        };
        if projection.is_none() && derived.is_none() {
            return Err(match unread {
                Some(reason) => format!("naga cannot read its vertex module ({reason})"),
                None => "Position does not come from a push-constant matrix".into(),
            });
        }
        // A stage that fits a matrix it loads whole from push constants: the CPU classifies
        // it too (the camera's range where it finds one, the fit otherwise), where the
        // layout's ranges and a static convention let it read the bytes.
        let projection = projection.or_else(|| {
            let (slot, convention, ranges) = (self.derived_slot?, self.convention?, self.ranges?);
            derived?;
            ProjectionUse::new(&slot, convention, ranges).ok()
        });
        self.unit_w_checked(stage)?;
        Ok(VertexRange {
            projection,
            derived,
            baked: false,
        })
    }

    /// The precise path of a pipeline whose layout has no room for the carrier: its stage
    /// fits the matrix it loads (from push constants too) with the carrier baked into the
    /// reversed variants' code. That needs the [0, 1] clip depth fixed in the pipeline (a
    /// baked selector cannot follow a dynamic convention) and the baked rewrite.
    fn decide_baked(&self, stage: LastStage) -> Result<VertexRange, String> {
        const NO_ROOM: &str = "its pipeline layout has no room for revz's push constants";
        match self.convention {
            Some(DepthConvention::ZeroToOne) => {}
            Some(DepthConvention::NegativeOneToOne) => {
                return Err(format!("{NO_ROOM}, and its clip depth is [-1, 1]"))
            }
            None => {
                return Err(format!(
                    "{NO_ROOM}, and its depth clip convention is dynamic"
                ))
            }
        }
        let derived = match &self.baked {
            None => return Err(NO_ROOM.into()),
            Some(Err(reason)) => {
                return Err(format!(
                    "{NO_ROOM}, and its {} stage cannot derive its range ({reason})",
                    stage.name()
                ))
            }
            Some(Ok(source)) => *source,
        };
        self.unit_w_checked(stage)?;
        Ok(VertexRange {
            projection: None,
            derived: Some(derived),
            baked: true,
        })
    }

    fn unit_w_checked(&self, stage: LastStage) -> Result<(), String> {
        if self.input_unit_w == Some(false) {
            let prior = match stage {
                LastStage::TessellationEvaluation => {
                    "which the control stage does not copy from a vertex stage storing \
                     vec4(p, 1.0)"
                }
                _ => {
                    "which that stage does not store as vec4(p, 1.0) (nor, an evaluation \
                     stage, interpolate from a control stage copying a vertex stage's \
                     vec4(p, 1.0))"
                }
            };
            return Err(format!(
                "its {} stage projects the previous stage's Position (gl_in[i].gl_Position), \
                 {prior}",
                stage.name()
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::analysis::ProjectionSlot;

    #[test]
    fn only_infinite_mode_sends_clamping_pipelines_to_the_flip_path() {
        assert!(depth_clamp_flip(RewriteTarget::Infinite, DepthClamp::On).is_some());
        for clamp in [
            DepthClamp::On,
            DepthClamp::OnClipped,
            DepthClamp::Dynamic,
            DepthClamp::Off,
        ] {
            assert_eq!(depth_clamp_flip(RewriteTarget::Complementary, clamp), None);
        }
        // Zink's pipelines all have a dynamic clamp, D3D translators' a clamp with clipping
        // kept on: they keep the precise path.
        for clamp in [DepthClamp::Off, DepthClamp::Dynamic, DepthClamp::OnClipped] {
            assert_eq!(depth_clamp_flip(RewriteTarget::Infinite, clamp), None);
        }
    }

    #[test]
    fn modules_are_analysed_for_fragments_when_active_and_for_vertices_when_rewriting() {
        assert!(analyses_fragment_module(true));
        assert!(!analyses_fragment_module(false));
        assert!(analyses_vertex_module(true, || true));
        assert!(!analyses_vertex_module(true, || false));
        // The module is not scanned where the mode does not rewrite.
        assert!(!analyses_vertex_module(false, || unreachable!()));
    }

    #[test]
    fn a_module_gets_a_position_store_with_the_carrier_the_deriving_one_where_naga_cannot_read_it()
    {
        let projection = [Analysis::Projection(slot())];
        let unread = [Analysis::Unreadable("no push constants".into())];
        assert_eq!(
            module_position_store(Some(128), Some(&projection)),
            Some((128, PositionStore::Carrier))
        );
        assert_eq!(
            module_position_store(Some(64), Some(&unread)),
            Some((64, PositionStore::Deriving))
        );
        assert_eq!(
            module_position_store(Some(64), Some(&[] as &[Analysis])),
            Some((64, PositionStore::Deriving))
        );
        assert_eq!(module_position_store(None, Some(&projection)), None);
        // naga could not read the module: the deriving rewrite, which needs no naga.
        assert_eq!(
            module_position_store(Some(64), None::<&[Analysis]>),
            Some((64, PositionStore::Deriving))
        );
        assert_eq!(module_position_store(None, None::<&[Analysis]>), None);
    }

    #[test]
    fn missing_facts_say_why_the_flip_path_is_taken() {
        use MissingFact as M;
        let all = [
            M::UnknownModule,
            M::ModuleWithoutRewrite,
            M::InlineWithoutRewrite,
            M::NoModule,
            M::NoVertexStage,
            M::UnreadableModule,
            M::NoEntryPointName,
            M::Incomplete,
        ];
        let reasons: std::collections::HashSet<_> = all.iter().map(|m| m.reason()).collect();
        assert_eq!(reasons.len(), all.len(), "each fact has its own reason");
        assert_eq!(M::NoVertexStage.reason(), "it has no vertex stage");
        assert_eq!(M::NoModule.reason(), "its vertex shader has no module");
    }

    #[test]
    fn an_entry_points_analysis_is_found_by_its_name() {
        let module: ModuleAnalysis = Ok(vec![
            ("main".to_owned(), Analysis::Unreadable("a".into())),
            ("other".to_owned(), Analysis::Unreadable("b".into())),
        ]);
        let found = entry_point_analysis(Ok(&module), Some(b"other"));
        assert!(matches!(found, Ok(Some(Analysis::Unreadable(r))) if r == "b"));
        assert!(matches!(
            entry_point_analysis(Ok(&module), Some(b"missing")),
            Ok(None)
        ));
        assert_eq!(
            entry_point_analysis(Ok(&module), None).map(|_| ()),
            Err("no entry point name")
        );
        let unreadable: ModuleAnalysis = Err("bad".into());
        // An unreadable module is said before a missing name.
        assert_eq!(
            entry_point_analysis(Ok(&unreadable), None).map(|_| ()),
            Err("naga cannot read its vertex module")
        );
        assert_eq!(
            entry_point_analysis(Err("its vertex module is unknown"), Some(b"main")).map(|_| ()),
            Err("its vertex module is unknown")
        );
    }

    #[test]
    fn a_pipeline_whose_rewritten_stage_is_not_made_takes_the_flip_path() {
        assert_eq!(unmade_stage_flip(true), None);
        assert_eq!(
            unmade_stage_flip(false),
            Some("its rewritten vertex stage could not be made")
        );
    }

    fn slot() -> ProjectionSlot {
        ProjectionSlot {
            offset: 0,
            matrix_stride: 16,
            row_major: false,
            columns: 4,
            rows: 4,
        }
    }

    const RANGES: [vk::PushConstantRange; 1] = [vk::PushConstantRange {
        stage_flags: vk::ShaderStageFlags::VERTEX,
        offset: 0,
        size: 64,
    }];

    /// A vertex stage whose projection is in push constants, everything revz needs known.
    fn pushed(analysis: &Analysis) -> VertexStageFacts<'_> {
        VertexStageFacts {
            code_given: true,
            last_stage: Some(LastStage::Vertex),
            carrier_reaches_stage: true,
            analysis: Ok(Some(analysis)),
            ranges: Some(&RANGES),
            convention: Some(DepthConvention::ZeroToOne),
            carrier_room: true,
            baked: None,
            rewrite: Ok(None),
            input_unit_w: None,
            derived_slot: None,
        }
    }

    #[test]
    fn a_projection_in_push_constants_with_a_rewritten_store_takes_the_precise_path() {
        let analysis = Analysis::Projection(slot());
        let range = pushed(&analysis).decide().unwrap();
        assert_eq!(range.projection.map(|p| p.offset), Some(0));
        assert_eq!(range.derived, None);
    }

    #[test]
    fn a_later_stage_fitting_a_pushed_matrix_gets_it_classified_where_the_cpu_can_read_it() {
        for stage in [
            LastStage::Mesh,
            LastStage::Geometry,
            LastStage::TessellationEvaluation,
        ] {
            let facts = VertexStageFacts {
                last_stage: Some(stage),
                analysis: Ok(None),
                rewrite: Ok(Some(MatrixSource::PushConstants)),
                derived_slot: Some(slot()),
                ..pushed(&Analysis::NoPushConstants)
            };
            let range = facts.decide().unwrap();
            assert_eq!(range.projection.map(|p| p.offset), Some(0), "{stage:?}");
            assert_eq!(range.derived, Some(MatrixSource::PushConstants));
            // A dynamic convention, or bytes outside the layout's ranges: the fit alone.
            for unreadable in [
                VertexStageFacts {
                    convention: None,
                    ..facts
                },
                VertexStageFacts {
                    derived_slot: Some(ProjectionSlot {
                        offset: 64,
                        ..slot()
                    }),
                    ..facts
                },
            ] {
                let range = unreadable.decide().unwrap();
                assert_eq!(range.projection, None, "{stage:?}");
                assert_eq!(range.derived, Some(MatrixSource::PushConstants));
            }
        }
    }

    #[test]
    fn a_stage_that_derives_its_range_takes_the_precise_path_without_a_pushed_projection() {
        let analysis = Analysis::NotFromPushConstants;
        let facts = VertexStageFacts {
            rewrite: Ok(Some(MatrixSource::UniformBuffer)),
            ..pushed(&analysis)
        };
        assert_eq!(
            facts.decide(),
            Ok(VertexRange {
                projection: None,
                derived: Some(MatrixSource::UniformBuffer),
                baked: false,
            })
        );
        // Without the rewrite's fit there is nothing to store depth with.
        let facts = VertexStageFacts {
            rewrite: Ok(None),
            ..facts
        };
        assert_eq!(
            facts.decide().unwrap_err(),
            "Position does not come from a push-constant matrix"
        );
    }

    #[test]
    fn a_layout_without_room_takes_the_precise_path_with_the_carrier_baked_in() {
        let analysis = Analysis::Projection(slot());
        let no_room = VertexStageFacts {
            carrier_room: false,
            carrier_reaches_stage: false,
            ranges: None,
            baked: Some(Ok(MatrixSource::PushConstants)),
            ..pushed(&analysis)
        };
        assert_eq!(
            no_room.decide(),
            Ok(VertexRange {
                projection: None,
                derived: Some(MatrixSource::PushConstants),
                baked: true,
            })
        );
        // What keeps it on the flip path, each with its reason.
        for (facts, reason) in [
            (
                VertexStageFacts {
                    baked: None,
                    ..no_room
                },
                "its pipeline layout has no room for revz's push constants",
            ),
            (
                VertexStageFacts {
                    baked: Some(Err("two stores")),
                    ..no_room
                },
                "its pipeline layout has no room for revz's push constants, and its vertex \
                 stage cannot derive its range (two stores)",
            ),
            (
                VertexStageFacts {
                    convention: None,
                    ..no_room
                },
                "its pipeline layout has no room for revz's push constants, and its depth \
                 clip convention is dynamic",
            ),
            (
                VertexStageFacts {
                    convention: Some(DepthConvention::NegativeOneToOne),
                    ..no_room
                },
                "its pipeline layout has no room for revz's push constants, and its clip \
                 depth is [-1, 1]",
            ),
        ] {
            assert_eq!(facts.decide().unwrap_err(), reason);
        }
        let projects_input = VertexStageFacts {
            last_stage: Some(LastStage::Geometry),
            input_unit_w: Some(false),
            ..no_room
        };
        assert!(projects_input
            .decide()
            .unwrap_err()
            .contains("does not store as vec4(p, 1.0)"));
        // A layout with room never takes it, whatever was made.
        let room = VertexStageFacts {
            carrier_room: true,
            carrier_reaches_stage: true,
            ranges: Some(&RANGES),
            ..no_room
        };
        assert!(!room.decide().unwrap().baked);
    }

    #[test]
    fn the_last_pre_rasterization_stage_is_the_latest_present() {
        use vk::ShaderStageFlags as S;
        let of = |stages: &[S]| LastStage::of(stages.iter().copied());
        assert_eq!(of(&[S::VERTEX, S::FRAGMENT]), Some(LastStage::Vertex));
        assert_eq!(
            of(&[
                S::VERTEX,
                S::TESSELLATION_CONTROL,
                S::TESSELLATION_EVALUATION
            ]),
            Some(LastStage::TessellationEvaluation)
        );
        // A geometry stage follows tessellation, in whatever order the stages are listed.
        assert_eq!(
            of(&[S::GEOMETRY, S::TESSELLATION_EVALUATION, S::VERTEX]),
            Some(LastStage::Geometry)
        );
        assert_eq!(of(&[S::TASK_EXT, S::MESH_EXT]), Some(LastStage::Mesh));
        assert_eq!(of(&[S::FRAGMENT]), None);
        assert_eq!(LastStage::Geometry.flag(), S::GEOMETRY);
    }

    #[test]
    fn stages_carrying_positions_on_hand_the_rewrite_to_the_stage_before() {
        use vk::ShaderStageFlags as S;
        let geometry = [S::VERTEX, S::GEOMETRY, S::FRAGMENT];
        let tessellated = [
            S::VERTEX,
            S::TESSELLATION_CONTROL,
            S::TESSELLATION_EVALUATION,
            S::GEOMETRY,
        ];
        let all = |_| true;
        let none = |_| false;
        let only = |carrying: &'static [S]| move |stage| carrying.contains(&stage);
        assert_eq!(
            LastStage::rewritten(&geometry, all),
            Some(LastStage::Vertex)
        );
        assert_eq!(
            LastStage::rewritten(&geometry, none),
            Some(LastStage::Geometry)
        );
        // Tessellation stages carry the positions on only both together.
        assert_eq!(
            LastStage::rewritten(&tessellated, all),
            Some(LastStage::Vertex)
        );
        assert_eq!(
            LastStage::rewritten(&tessellated, only(&[S::GEOMETRY])),
            Some(LastStage::TessellationEvaluation)
        );
        assert_eq!(
            LastStage::rewritten(
                &tessellated,
                only(&[S::GEOMETRY, S::TESSELLATION_EVALUATION])
            ),
            Some(LastStage::TessellationEvaluation)
        );
        // A geometry stage that computes keeps being the last, whatever comes before it.
        assert_eq!(
            LastStage::rewritten(
                &tessellated,
                only(&[S::TESSELLATION_CONTROL, S::TESSELLATION_EVALUATION])
            ),
            Some(LastStage::Geometry)
        );
        assert_eq!(
            LastStage::rewritten(&tessellated[..3], all),
            Some(LastStage::Vertex)
        );
        // Only geometry and tessellation stages are asked.
        assert_eq!(
            LastStage::rewritten(&[S::VERTEX, S::FRAGMENT], |_| unreachable!()),
            Some(LastStage::Vertex)
        );
    }

    #[test]
    fn a_vertex_module_naga_cannot_read_takes_the_deriving_route() {
        // Zink's module of glmark2's `terrain` (naga: "invalid id"): the module as a whole, or
        // the entry point's analysis; the deriving rewrite reads the words itself.
        let entry_unread = Analysis::Unreadable("invalid id %359".into());
        for analysis in [
            Err(MissingFact::UnreadableModule.reason()),
            Ok(Some(&entry_unread)),
        ] {
            let facts = VertexStageFacts {
                analysis,
                rewrite: Ok(Some(MatrixSource::UniformBuffer)),
                ..pushed(&Analysis::NoPushConstants)
            };
            let range = facts.decide().expect("the derived route");
            assert_eq!(range.derived, Some(MatrixSource::UniformBuffer));
            assert_eq!(range.projection, None);
        }
        // Other missing facts still say why.
        let facts = VertexStageFacts {
            analysis: Err(MissingFact::UnknownModule.reason()),
            rewrite: Ok(Some(MatrixSource::UniformBuffer)),
            ..pushed(&Analysis::NoPushConstants)
        };
        assert_eq!(
            facts.decide().unwrap_err(),
            MissingFact::UnknownModule.reason()
        );
    }

    #[test]
    fn a_later_stage_that_derives_its_range_takes_the_precise_path_where_the_carrier_reaches_it() {
        // naga reads no geometry, tessellation or mesh stage: no analysis, the deriving
        // rewrite.
        for stage in [
            LastStage::Geometry,
            LastStage::TessellationEvaluation,
            LastStage::Mesh,
        ] {
            let facts = VertexStageFacts {
                last_stage: Some(stage),
                analysis: Ok(None),
                rewrite: Ok(Some(MatrixSource::UniformBuffer)),
                ..pushed(&Analysis::NoPushConstants)
            };
            assert_eq!(
                facts.decide(),
                Ok(VertexRange {
                    projection: None,
                    derived: Some(MatrixSource::UniformBuffer),
                    baked: false,
                })
            );
            // Projecting gl_in's Position: as the stage before stores it.
            let projects_input = |w_one| VertexStageFacts {
                input_unit_w: Some(w_one),
                ..facts
            };
            assert!(projects_input(true).decide().is_ok());
            let refused = projects_input(false).decide().unwrap_err();
            assert!(refused.contains("projects the previous stage's Position"));
            // An evaluation stage reads the control stage's copies of the vertex stage's
            // positions (session 38): the reason names both.
            assert_eq!(
                refused.contains("the control stage does not copy from a vertex stage"),
                stage == LastStage::TessellationEvaluation,
                "{refused}"
            );
            let unreached = VertexStageFacts {
                carrier_reaches_stage: false,
                ..facts
            };
            assert!(unreached
                .decide()
                .unwrap_err()
                .contains("revz's push constants do not reach its"));
        }
    }

    #[test]
    fn each_missing_fact_gives_its_reason_in_order() {
        let analysis = Analysis::Projection(slot());
        let base = pushed(&analysis);
        let reason = |facts: VertexStageFacts<'_>| facts.decide().unwrap_err();
        let cases: Vec<(VertexStageFacts<'_>, &str)> = vec![
            (
                VertexStageFacts {
                    code_given: false,
                    last_stage: Some(LastStage::Mesh),
                    ..base
                },
                "its code is not given",
            ),
            (
                VertexStageFacts {
                    last_stage: None,
                    ..base
                },
                "it has no vertex stage",
            ),
            (
                VertexStageFacts {
                    analysis: Err("naga cannot read its vertex module"),
                    rewrite: Err(Missing::Unsupported(Unsupported("two stores"))),
                    ..base
                },
                "naga cannot read its vertex module (its module as a whole), and its vertex \
                 stage cannot derive its range (two stores)",
            ),
            (
                VertexStageFacts {
                    ranges: None,
                    ..base
                },
                "its pipeline layout is unknown",
            ),
            (
                VertexStageFacts {
                    convention: None,
                    ..base
                },
                "its depth clip convention is dynamic",
            ),
            (
                VertexStageFacts {
                    carrier_room: false,
                    carrier_reaches_stage: false,
                    ..base
                },
                "no room for revz's push constants",
            ),
            (
                VertexStageFacts {
                    last_stage: Some(LastStage::Geometry),
                    carrier_reaches_stage: false,
                    ..base
                },
                "do not reach its geometry stage",
            ),
            (
                VertexStageFacts {
                    rewrite: Err(Missing::NotMade(
                        "its vertex module has no Position rewrite",
                    )),
                    ..base
                },
                "has no Position rewrite",
            ),
            (
                VertexStageFacts {
                    rewrite: Err(Missing::Unsupported(Unsupported("two stores"))),
                    ..base
                },
                "its Position store cannot be rewritten (",
            ),
        ];
        for (facts, expected) in cases {
            let got = reason(facts);
            assert!(got.contains(expected), "{got:?} does not say {expected:?}");
        }
        let unreadable = Analysis::Unreadable("a loop".into());
        assert_eq!(
            reason(pushed(&unreadable)),
            "naga cannot read its vertex module (a loop)"
        );
    }

    #[test]
    fn a_stage_without_a_pushed_projection_needs_zero_to_one_clip_depth_and_a_fit() {
        let analysis = Analysis::NotFromPushConstants;
        let facts = VertexStageFacts {
            convention: Some(DepthConvention::NegativeOneToOne),
            rewrite: Ok(Some(MatrixSource::UniformBuffer)),
            ..pushed(&analysis)
        };
        assert!(facts.decide().unwrap_err().contains("[-1, 1]"));
        // A dynamic convention is followed per draw by a deriving stage.
        let facts = VertexStageFacts {
            convention: None,
            ..facts
        };
        assert!(facts.decide().is_ok());
        let facts = VertexStageFacts {
            rewrite: Err(Missing::Unsupported(Unsupported("two stores"))),
            ..facts
        };
        assert!(facts
            .decide()
            .unwrap_err()
            .starts_with("its projection is not in push constants, and its vertex stage cannot"));
    }

    #[test]
    fn only_depth_rendering_pipelines_defining_their_shaders_in_a_rewriting_mode_are_candidates() {
        assert!(precise_candidate(true, true, true));
        for facts in [
            (false, true, true),
            (true, false, true),
            (true, true, false),
        ] {
            assert!(!precise_candidate(facts.0, facts.1, facts.2));
        }
    }

    #[test]
    fn a_module_with_a_pushed_projection_stores_the_carrier_and_others_derive() {
        let pushed = Analysis::Projection(slot());
        let other = Analysis::NotFromPushConstants;
        assert_eq!(position_store([&other, &pushed]), PositionStore::Carrier);
        assert_eq!(position_store([&other]), PositionStore::Deriving);
        assert_eq!(position_store([]), PositionStore::Deriving);
    }
}
