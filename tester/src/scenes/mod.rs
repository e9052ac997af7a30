//! The scene catalog: one builder per `--scene`, each returning a [`Scene`] (objects plus the
//! [`Plan`] that records them).
//!
//! Every scene but `overlap` exists to exercise one thing a reversed-depth layer must change
//! (see DESIGN.md section 2) and is built so that the color image would be visibly wrong if
//! the layer forgot it. The scenes of the precise path (`projection-only` to `threads`) are
//! the overlap scene, or one like it, reached through another way of handing the projection
//! to the shader; they are drawn by one camera with LESS (the nearest surface wins), so the
//! tester computes their ground truth (`ground_truth`) and the tests check the depth values
//! the layer produces, not just the image. Each builder's documentation says which item and how. The tester
//! itself knows nothing of the layer: these are ordinary standard-depth renders (clear 1.0,
//! LESS), and the claims about depth values (which object lies on which side of a clear value
//! or bound, with margins far above any format's resolution, so that no pixel sits on a tie)
//! are checked in the unit tests (`tests.rs`). The builders live by concern: `state.rs`
//! (compare ops, clears, bias, bounds, viewports, stencil), `passes.rs` (secondaries, subpasses,
//! dynamic rendering and its local reads, shadow map, resolves, fragment depth, libraries),
//! `precise.rs` (the precise path's ways of handing over the projection).
//!
//! Depths quoted below are for the `overlap` camera (eye (0, 2, 6) looking at the origin, near
//! 0.1, far 100): a surface at view distance z gets depth 1.001 * (1 - 0.1 / z), so z = 3 ->
//! 0.967, 4 -> 0.976, 4.77 -> 0.98, 6.27 -> 0.985, 10 -> 0.991.

use glam::{DMat4, DVec3};

use crate::accuracy::scenes as accuracy;
use crate::plan::{
    Bias, Bounds, Compare, DepthBias, DepthLayout, DepthLoad, DepthTest, Multisample, PassKind,
    PassSpec, PipelineSpec, Plan, Program, Recording, ResolveMode, StencilTest, StencilWrite, Step,
    Target, Viewport,
};
use crate::scene::{
    grounded_cube, overlap, overlap_camera, overlap_objects, rgb8, Camera, Light, Mesh, Object,
    Projection, Scene, SceneId, Space,
};

/// One row of the catalog.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// The scene.
    pub id: SceneId,
    /// Its CLI / report name.
    pub name: &'static str,
    /// Its builder.
    pub build: fn() -> Scene,
}

/// Every scene, in CLI order.
pub const CATALOG: &[Entry] = &[
    entry_row(SceneId::Overlap, "overlap", overlap),
    entry_row(SceneId::CompareOps, "compare-ops", compare_ops),
    entry_row(
        SceneId::CompareOpsDynamic,
        "compare-ops-dynamic",
        compare_ops_dynamic,
    ),
    entry_row(
        SceneId::CompareOpsUnsorted,
        "compare-ops-unsorted",
        compare_ops_unsorted,
    ),
    entry_row(
        SceneId::ClearRenderPass,
        "clear-render-pass",
        clear_render_pass,
    ),
    entry_row(
        SceneId::ClearAttachments,
        "clear-attachments",
        clear_attachments,
    ),
    entry_row(SceneId::ClearImage, "clear-image", clear_image),
    entry_row(SceneId::DepthBias, "depth-bias", depth_bias),
    entry_row(
        SceneId::DepthBiasDynamic,
        "depth-bias-dynamic",
        depth_bias_dynamic,
    ),
    entry_row(SceneId::DepthBounds, "depth-bounds", depth_bounds),
    entry_row(SceneId::ViewportSky, "viewport-sky", viewport_sky),
    entry_row(SceneId::ViewportSplit, "viewport-split", viewport_split),
    entry_row(
        SceneId::DepthRangeUnrestricted,
        "depth-range-unrestricted",
        depth_range_unrestricted,
    ),
    entry_row(
        SceneId::DepthRangeUnrestrictedClearOne,
        "depth-range-unrestricted-clear-one",
        depth_range_unrestricted_clear_one,
    ),
    entry_row(SceneId::Stencil, "stencil", stencil),
    entry_row(SceneId::Secondary, "secondary", secondary),
    entry_row(SceneId::Subpasses, "subpasses", subpasses),
    entry_row(
        SceneId::DynamicRendering,
        "dynamic-rendering",
        dynamic_rendering,
    ),
    entry_row(
        SceneId::DynamicRenderingSuspended,
        "dynamic-rendering-suspended",
        dynamic_rendering_suspended,
    ),
    entry_row(
        SceneId::DynamicRenderingSuspendedAcross,
        "dynamic-rendering-suspended-across",
        dynamic_rendering_suspended_across,
    ),
    entry_row(
        SceneId::DynamicRenderingSecondaries,
        "dynamic-rendering-secondaries",
        dynamic_rendering_secondaries,
    ),
    entry_row(SceneId::ShadowMap, "shadow-map", shadow_map),
    entry_row(
        SceneId::ShadowMapSecondaries,
        "shadow-map-secondaries",
        shadow_map_secondaries,
    ),
    entry_row(SceneId::ShadowMapRaw, "shadow-map-raw", shadow_map_raw),
    entry_row(
        SceneId::ShadowMapX8D24,
        "shadow-map-x8-d24",
        shadow_map_x8_d24,
    ),
    entry_row(
        SceneId::ShadowMapPerspective,
        "shadow-map-perspective",
        shadow_map_perspective,
    ),
    entry_row(
        SceneId::ShadowMapPerspectiveSecondaries,
        "shadow-map-perspective-secondaries",
        shadow_map_perspective_secondaries,
    ),
    entry_row(SceneId::DepthReads, "depth-reads", depth_reads),
    entry_row(SceneId::StencilReads, "stencil-reads", stencil_reads),
    entry_row(SceneId::DeferredDepth, "deferred-depth", deferred_depth),
    entry_row(
        SceneId::DeferredDepthTested,
        "deferred-depth-tested",
        deferred_depth_tested,
    ),
    entry_row(
        SceneId::DeferredDepthLibrary,
        "deferred-depth-library",
        deferred_depth_library,
    ),
    entry_row(
        SceneId::DeferredDepthTestedLibrary,
        "deferred-depth-tested-library",
        deferred_depth_tested_library,
    ),
    entry_row(
        SceneId::DeferredDepthSecondaries,
        "deferred-depth-secondaries",
        deferred_depth_secondaries,
    ),
    entry_row(
        SceneId::DeferredDepthLocalRead,
        "deferred-depth-local-read",
        deferred_depth_local_read,
    ),
    entry_row(
        SceneId::DeferredDepthLocalReadIndexed,
        "deferred-depth-local-read-indexed",
        deferred_depth_local_read_indexed,
    ),
    entry_row(
        SceneId::DeferredDepthLocalReadTested,
        "deferred-depth-local-read-tested",
        deferred_depth_local_read_tested,
    ),
    entry_row(SceneId::DepthMips, "depth-mips", depth_mips),
    entry_row(SceneId::DepthLayers, "depth-layers", depth_layers),
    entry_row(
        SceneId::DepthLayersStepwise,
        "depth-layers-stepwise",
        depth_layers_stepwise,
    ),
    entry_row(SceneId::Multiview, "multiview", multiview),
    entry_row(
        SceneId::MultiviewDynamic,
        "multiview-dynamic",
        multiview_dynamic,
    ),
    entry_row(SceneId::MsaaResolve, "msaa-resolve", msaa_resolve),
    entry_row(
        SceneId::MsaaResolveDynamic,
        "msaa-resolve-dynamic",
        msaa_resolve_dynamic,
    ),
    entry_row(
        SceneId::DepthReadsMsaa,
        "depth-reads-msaa",
        depth_reads_msaa,
    ),
    entry_row(SceneId::FragDepth, "frag-depth", frag_depth),
    entry_row(
        SceneId::FragDepthLibrary,
        "frag-depth-library",
        frag_depth_library,
    ),
    entry_row(
        SceneId::FragDepthLibraryDynamic,
        "frag-depth-library-dynamic",
        frag_depth_library_dynamic,
    ),
    entry_row(
        SceneId::PipelineLibrary,
        "pipeline-library",
        pipeline_library,
    ),
    entry_row(
        SceneId::PipelineLibraryDynamic,
        "pipeline-library-dynamic",
        pipeline_library_dynamic,
    ),
    entry_row(SceneId::ProjectionOnly, "projection-only", projection_only),
    entry_row(SceneId::ViewProjection, "view-projection", view_projection),
    entry_row(
        SceneId::ModelViewProjectionPair,
        "model-view-projection-pair",
        model_view_projection_pair,
    ),
    entry_row(SceneId::RowMajor, "row-major", row_major),
    entry_row(SceneId::OpenglDepth, "opengl-depth", opengl_depth),
    entry_row(
        SceneId::AlreadyReversed,
        "already-reversed",
        already_reversed,
    ),
    entry_row(SceneId::PushPartial, "push-partial", push_partial),
    entry_row(SceneId::Threads, "threads", threads),
    entry_row(SceneId::LitMvp, "lit-mvp", lit_mvp),
    entry_row(SceneId::SlopedPlane, "sloped-plane", accuracy::sloped_plane),
    entry_row(SceneId::MarsPatch, "mars-patch", accuracy::mars_patch),
    entry_row(SceneId::Tori, "tori", accuracy::tori),
    entry_row(SceneId::PlaneStack, "plane-stack", accuracy::plane_stack),
    entry_row(SceneId::DeepRange, "deep-range", accuracy::deep_range),
    entry_row(SceneId::DecalBias, "decal-bias", accuracy::decal_bias),
    entry_row(SceneId::FarObjects, "far-objects", accuracy::far_objects),
];

const fn entry_row(id: SceneId, name: &'static str, build: fn() -> Scene) -> Entry {
    Entry { id, name, build }
}

/// The catalog row of `id`.
pub fn entry(id: SceneId) -> &'static Entry {
    CATALOG
        .iter()
        .find(|e| e.id == id)
        .expect("every SceneId has a catalog row (checked by a unit test)")
}

/// Collects objects, passes, pipelines and steps, handing out the indices steps refer to.
#[derive(Debug, Default)]
struct Builder {
    objects: Vec<Object>,
    passes: Vec<PassSpec>,
    pipelines: Vec<PipelineSpec>,
    steps: Vec<Step>,
}

impl Builder {
    fn object(&mut self, object: Object) -> usize {
        self.objects.push(object);
        self.objects.len() - 1
    }

    /// Adds `objects` sorted nearest first for `camera`; returns their indices in that order.
    fn nearest_first(&mut self, camera: &Camera, mut objects: Vec<Object>) -> Vec<usize> {
        let depth = |o: &Object| (o.world_center() - camera.eye).dot(camera.forward());
        objects.sort_by(|a, b| depth(a).total_cmp(&depth(b)));
        objects.into_iter().map(|o| self.object(o)).collect()
    }

    fn pass(&mut self, pass: PassSpec) -> usize {
        self.passes.push(pass);
        self.passes.len() - 1
    }

    fn pipeline(&mut self, pipeline: PipelineSpec) -> usize {
        self.pipelines.push(pipeline);
        self.pipelines.len() - 1
    }

    fn step(&mut self, step: Step) {
        self.steps.push(step);
    }

    fn draw(&mut self, objects: &[usize]) {
        self.steps.extend(objects.iter().map(|&n| Step::Draw(n)));
    }

    fn finish(self, name: &'static str, camera: Camera, light: Option<Light>) -> Scene {
        Scene {
            name,
            camera,
            light,
            objects: self.objects,
            plan: Plan {
                passes: self.passes,
                pipelines: self.pipelines,
                steps: self.steps,
            },
        }
    }
}

/// A pipeline of pass 0 like the standard one but with another depth test and no depth
/// writes (color passes over a depth pre-pass, overlays).
fn test_only(name: &'static str, depth_test: DepthTest) -> PipelineSpec {
    PipelineSpec {
        depth_test,
        depth_write: false,
        ..PipelineSpec::standard(name, 0)
    }
}

/// The overlap objects with the ground split into an 8 x 8 grid of tiles (same plane, same
/// size), plus the checkerboard of half of those tiles drawn as a coplanar overlay.
fn tiled_overlap_objects() -> (Vec<Object>, Object) {
    let mut objects = overlap_objects();
    let ground = objects
        .iter_mut()
        .find(|o| o.name == "ground")
        .expect("overlap has a ground");
    ground.mesh = Mesh::grid(10.0, 10.0, 8, |_, _| true);
    let checker = Object {
        name: "checker overlay",
        mesh: Mesh::grid(10.0, 10.0, 8, |i, j| (i + j) % 2 == 0),
        color: rgb8(240, 150, 200),
        ..ground.clone()
    };
    (objects, checker)
}

/// The extra objects of the compare-ops scenes: (GREATER silhouette, ALWAYS x-ray, NEVER).
fn compare_extras() -> [Object; 3] {
    [
        // Partly behind the near cube: GREATER draws only its occluded part, over the near
        // cube.
        grounded_cube("greater cube", 0.3, -0.3, 1.1, 0.6, rgb8(255, 140, 0)),
        // Entirely behind the middle cube: ALWAYS draws it over the middle cube.
        grounded_cube("always cube", 0.3, 0.45, -1.45, 0.3, rgb8(0, 230, 230)),
        // In front of everything, on the ground: NEVER must not show.
        grounded_cube("never cube", 0.3, 0.75, 3.3, 0.1, rgb8(255, 255, 255)),
    ]
}

mod multiview;
mod passes;
mod precise;
mod state;

pub use multiview::*;
pub use passes::*;
pub use precise::*;
pub use state::*;

#[cfg(test)]
mod tests;
