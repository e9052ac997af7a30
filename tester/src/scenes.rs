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
//! are checked in the unit tests below.
//!
//! Depths quoted below are for the `overlap` camera (eye (0, 2, 6) looking at the origin, near
//! 0.1, far 100): a surface at view distance z gets depth 1.001 * (1 - 0.1 / z), so z = 3 ->
//! 0.967, 4 -> 0.976, 4.77 -> 0.98, 6.27 -> 0.985, 10 -> 0.991.

use glam::{DMat4, DVec3};

use crate::accuracy::scenes as accuracy;
use crate::plan::{
    Bias, Bounds, Compare, DepthBias, DepthLoad, DepthTest, Multisample, PassKind, PassSpec,
    PipelineSpec, Plan, Program, Recording, ResolveMode, StencilTest, StencilWrite, Step, Target,
    Viewport,
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
    entry_row(SceneId::Stencil, "stencil", stencil),
    entry_row(SceneId::Secondary, "secondary", secondary),
    entry_row(SceneId::Subpasses, "subpasses", subpasses),
    entry_row(
        SceneId::DynamicRendering,
        "dynamic-rendering",
        dynamic_rendering,
    ),
    entry_row(SceneId::ShadowMap, "shadow-map", shadow_map),
    entry_row(
        SceneId::ShadowMapSecondaries,
        "shadow-map-secondaries",
        shadow_map_secondaries,
    ),
    entry_row(SceneId::MsaaResolve, "msaa-resolve", msaa_resolve),
    entry_row(
        SceneId::MsaaResolveDynamic,
        "msaa-resolve-dynamic",
        msaa_resolve_dynamic,
    ),
    entry_row(SceneId::FragDepth, "frag-depth", frag_depth),
    entry_row(
        SceneId::FragDepthLibrary,
        "frag-depth-library",
        frag_depth_library,
    ),
    entry_row(
        SceneId::PipelineLibrary,
        "pipeline-library",
        pipeline_library,
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

/// `compare-ops`: static compare ops. A depth pre-pass (LESS, color writes off) of the
/// overlap objects (ground split into tiles), then a color pass with EQUAL over the same
/// geometry (drawn farthest first, so that ties show what a single LESS pass would), a checkerboard overlay made of the very same ground tiles drawn with
/// LESS_OR_EQUAL (visible on the ground, hidden behind the cubes), a cube drawn with GREATER
/// (only its part hidden behind the near cube shows, painted over it), one with ALWAYS (shows
/// through the middle cube) and one with NEVER in front of everything (must not show).
///
/// Layer item: compare-op swap in pipelines (LESS<->GREATER, LESS_OR_EQUAL<->GREATER_OR_EQUAL,
/// EQUAL, ALWAYS and NEVER kept). Without the swap the pre-pass LESS fails against the
/// reversed clear (nothing is written, so the EQUAL pass draws nothing: only the ALWAYS cube
/// on the background); an unswapped LESS_OR_EQUAL paints the checkerboard over the cubes; an
/// unswapped GREATER shows the visible part of its cube instead of the hidden one; NEVER or
/// ALWAYS mapped to anything else makes the white cube appear or the cyan one vanish.
pub fn compare_ops() -> Scene {
    compare_ops_scene("compare-ops", false)
}

/// `compare-ops-dynamic`: the `compare-ops` image made with `VK_DYNAMIC_STATE_DEPTH_COMPARE_OP`:
/// a pre-pass pipeline and one color pipeline whose op is set with `vkCmdSetDepthCompareOp`
/// (Vulkan 1.3 core) between draws: LESS for the pre-pass, then EQUAL, LESS_OR_EQUAL,
/// GREATER, ALWAYS and NEVER in the color pipeline.
///
/// Layer item: compare-op swap of the dynamic state (`vkCmdSetDepthCompareOp`), not just of
/// pipelines; the image is wrong in the same ways as `compare-ops` if it is missed.
pub fn compare_ops_dynamic() -> Scene {
    compare_ops_scene("compare-ops-dynamic", true)
}

fn compare_ops_scene(name: &'static str, dynamic: bool) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let (objects, checker) = tiled_overlap_objects();
    let opaque = b.nearest_first(&camera, objects);
    let checker = b.object(checker);
    let [greater, always, never] = compare_extras().map(|o| b.object(o));
    b.pass(PassSpec::clear(1.0));

    let prepass = PipelineSpec {
        color_write: false,
        depth_test: if dynamic {
            DepthTest::Dynamic
        } else {
            DepthTest::Static(Compare::Less)
        },
        ..PipelineSpec::standard("pre-pass", 0)
    };
    let prepass = b.pipeline(prepass);
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(prepass));
    if dynamic {
        b.step(Step::SetDepthCompareOp(Compare::Less));
    }
    b.draw(&opaque);

    // Farthest first: where surfaces tie, the one the LESS pre-pass kept (the nearest-first
    // draw order's first) is drawn last, as a single LESS pass would show it.
    let reversed: Vec<usize> = opaque.iter().rev().copied().collect();
    let color_draws: [(Compare, &[usize]); 5] = [
        (Compare::Equal, &reversed),
        (Compare::LessOrEqual, &[checker]),
        (Compare::Greater, &[greater]),
        (Compare::Always, &[always]),
        (Compare::Never, &[never]),
    ];
    if dynamic {
        let color = b.pipeline(test_only("color (dynamic op)", DepthTest::Dynamic));
        b.step(Step::Bind(color));
        for (op, objects) in color_draws {
            b.step(Step::SetDepthCompareOp(op));
            b.draw(objects);
        }
    } else {
        for (op, objects) in color_draws {
            let pipeline = b.pipeline(test_only("color", DepthTest::Static(op)));
            b.step(Step::Bind(pipeline));
            b.draw(objects);
        }
    }
    b.step(Step::EndPass);
    b.finish(name, camera, None)
}

/// The objects of the clear-value scenes, by distance: a near floor strip and two cubes
/// (depth < 0.9785), a middle cube (0.981 to 0.9842), a far floor and two far cubes
/// (> 0.987). Nothing lies between 0.9785 and 0.981 or between 0.9842 and 0.987, so the
/// clear values 0.98 and 0.985 never tie with a surface.
fn threshold_objects() -> Vec<Object> {
    vec![
        Object::world(
            "near floor",
            Mesh::quad(6.0, 2.0),
            DMat4::from_translation(DVec3::new(0.0, 0.0, 4.0)),
            rgb8(150, 60, 170),
        ),
        grounded_cube("near cube", 0.4, -0.9, 3.2, 0.4, rgb8(230, 30, 30)),
        grounded_cube("near cube 2", 0.35, 1.0, 2.6, -0.3, rgb8(30, 200, 40)),
        grounded_cube("middle cube", 0.3, 0.2, 0.85, 0.5, rgb8(250, 210, 20)),
        Object::world(
            "far floor",
            Mesh::quad(10.0, 6.5),
            DMat4::from_translation(DVec3::new(0.0, 0.0, -7.5)),
            rgb8(90, 90, 200),
        ),
        grounded_cube("far cube", 1.0, -0.8, -3.0, 0.2, rgb8(40, 80, 240)),
        grounded_cube("far cube 2", 0.8, 1.5, -6.0, -0.4, rgb8(200, 100, 40)),
    ]
}

/// `clear-render-pass`: the render pass clears depth to 0.985 (not 1.0); the near floor, the
/// near cubes and the middle cube (all nearer than 0.985) draw, the far floor and far cubes
/// (all beyond it) do not: the background shows where they would be.
///
/// Layer item: the depth clear value of `vkCmdBeginRenderPass` (d -> 1 - d). If it were not
/// flipped while the compare op is, the reversed test `1 - D > 0.985` would pass only for
/// depths below 0.015: nothing would draw.
pub fn clear_render_pass() -> Scene {
    threshold_scene("clear-render-pass", false)
}

/// `clear-image`: `vkCmdClearDepthStencilImage` clears the depth image (TRANSFER_DST usage)
/// to 0.98 outside any render pass (stencil to 0 where there is one), then a render pass
/// loads it (LOAD_OP_LOAD) and draws the `clear-render-pass` objects: only the near floor and
/// the near cubes (nearer than 0.98) show; the middle cube, which does show in
/// `clear-render-pass`, does not.
///
/// Layer item: the clear value of `vkCmdClearDepthStencilImage`. Unflipped, the reversed test
/// passes only below depth 0.02: nothing draws.
pub fn clear_image() -> Scene {
    threshold_scene("clear-image", true)
}

fn threshold_scene(name: &'static str, clear_image: bool) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, threshold_objects());
    if clear_image {
        b.step(Step::ClearDepthImage { depth: 0.98 });
        b.pass(PassSpec {
            depth: DepthLoad::Load,
            ..PassSpec::clear(1.0)
        });
    } else {
        b.pass(PassSpec::clear(0.985));
    }
    let standard = b.pipeline(PipelineSpec::standard("standard", 0));
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.draw(&objects);
    b.step(Step::EndPass);
    b.finish(name, camera, None)
}

/// The depth rectangle cleared by `clear-attachments`, as fractions of the image.
pub const CLEAR_RECT: [f32; 4] = [0.3, 0.3, 0.7, 0.7];

/// `clear-attachments`: first the ground and a low wall (nearer than 0.98) are drawn; then
/// `vkCmdClearAttachments` sets the depth of the middle rectangle (30%..70% of the image) to
/// 0.98; then a bar behind the wall (nearer than 0.98) and a wide far block (beyond 0.98) are
/// drawn. Outside the rectangle the wall hides the bar and the far block shows; inside it the
/// bar shows over the wall (its depth was cleared) and the far block is cut out, leaving a
/// rectangular notch.
///
/// Layer item: the clear value of `vkCmdClearAttachments`. Unflipped, the rectangle would hold
/// 0.98 in reversed depth where only fragments nearer than depth 0.02 pass: the bar would not
/// show inside it.
pub fn clear_attachments() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let before = b.nearest_first(
        &camera,
        vec![
            Object::world(
                "ground",
                Mesh::quad(10.0, 10.0),
                DMat4::from_translation(DVec3::new(0.0, 0.0, -4.0)),
                rgb8(150, 60, 170),
            ),
            Object::world(
                "wall",
                Mesh::cuboid(DVec3::new(0.8, 0.55, 0.05)),
                DMat4::from_translation(DVec3::new(0.0, 0.52, 3.2)),
                rgb8(230, 120, 30),
            ),
        ],
    );
    let after = b.nearest_first(
        &camera,
        vec![
            Object::world(
                "bar behind the wall",
                Mesh::cuboid(DVec3::new(1.0, 0.2, 0.15)),
                DMat4::from_translation(DVec3::new(0.0, 0.25, 2.1)),
                rgb8(30, 200, 40),
            ),
            Object::world(
                "far block",
                Mesh::cuboid(DVec3::new(2.0, 1.0, 0.5)),
                DMat4::from_translation(DVec3::new(0.0, 0.95, -2.0)),
                rgb8(40, 80, 240),
            ),
        ],
    );
    b.pass(PassSpec::clear(1.0));
    let standard = b.pipeline(PipelineSpec::standard("standard", 0));
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.draw(&before);
    b.step(Step::ClearDepthRect {
        rect: CLEAR_RECT,
        depth: 0.98,
    });
    b.draw(&after);
    b.step(Step::EndPass);
    b.finish("clear-attachments", camera, None)
}

/// The model matrix of the wall that faces the camera in the depth-bias scenes.
fn facing_wall_model() -> DMat4 {
    // The camera looks down by atan(2 / 6); tilting the wall back by that much makes its
    // normal point straight at the camera, so its depth is constant (no slope).
    DMat4::from_translation(DVec3::new(0.6, 1.05, -1.0))
        * DMat4::from_rotation_x(-(2.0f64 / 6.0).atan())
}

/// The model matrix of the slanted wall (seen at a grazing angle: a steep depth slope).
fn slanted_wall_model() -> DMat4 {
    DMat4::from_translation(DVec3::new(-1.05, 0.95, 1.2))
        * DMat4::from_rotation_y(62f64.to_radians())
}

/// The depth-bias scenes' objects: (walls and ground, decals with their wall's model).
/// The decals are rectangles in their wall's plane (local z = 0, same model matrix): exactly
/// coplanar, so without bias they z-fight or vanish under LESS. A rod 0.1 in front of the
/// slanted wall crosses its lower decal.
fn bias_objects() -> (Vec<Object>, Vec<Object>) {
    let facing = facing_wall_model();
    let slanted = slanted_wall_model();
    let walls = vec![
        Object::world(
            "ground",
            Mesh::quad(10.0, 10.0),
            DMat4::from_translation(DVec3::new(0.0, 0.0, -4.0)),
            rgb8(150, 60, 170),
        ),
        Object::world(
            "facing wall",
            Mesh::rect_xy(0.0, 0.0, 1.6, 1.0),
            facing,
            rgb8(200, 200, 190),
        ),
        Object::world(
            "slanted wall",
            Mesh::rect_xy(0.0, 0.0, 1.2, 0.9),
            slanted,
            rgb8(170, 170, 200),
        ),
        Object::world(
            "rod",
            Mesh::cuboid(DVec3::new(1.3, 0.04, 0.04)),
            slanted * DMat4::from_translation(DVec3::new(0.0, -0.35, 0.1)),
            rgb8(60, 60, 60),
        ),
    ];
    let decals = vec![
        Object::world(
            "facing decal 1",
            Mesh::rect_xy(-0.75, 0.35, 0.45, 0.3),
            facing,
            rgb8(230, 30, 30),
        ),
        Object::world(
            "facing decal 2",
            Mesh::rect_xy(0.7, -0.35, 0.5, 0.35),
            facing,
            rgb8(30, 160, 40),
        ),
        Object::world(
            "slanted decal 1",
            Mesh::rect_xy(0.1, 0.4, 0.7, 0.25),
            slanted,
            rgb8(40, 80, 240),
        ),
        Object::world(
            "slanted decal under the rod",
            Mesh::rect_xy(0.1, -0.35, 0.7, 0.25),
            slanted,
            rgb8(250, 190, 20),
        ),
    ];
    (walls, decals)
}

/// The static bias of `depth-bias` (standard depth: negative pulls toward the camera).
pub const DECAL_BIAS: DepthBias = DepthBias {
    constant: -8.0,
    slope: -12.0,
    clamp: -1.0e-4,
};

/// The per-decal biases of `depth-bias-dynamic`, in decal order.
pub const DECAL_BIASES: [DepthBias; 4] = [
    DepthBias {
        constant: -4.0,
        slope: -1.0,
        clamp: -1.0e-4,
    },
    DepthBias {
        constant: -16.0,
        slope: -2.0,
        clamp: -2.0e-4,
    },
    DepthBias {
        constant: -8.0,
        slope: -4.0,
        clamp: -1.0e-4,
    },
    DepthBias {
        constant: -2.0,
        slope: -20.0,
        clamp: -1.0e-4,
    },
];

/// `depth-bias`: decals coplanar with two walls (one facing the camera: constant depth, the
/// constant factor does the work; one slanted: the slope factor does), drawn after the walls
/// with LESS, no depth writes and a static bias pulling them toward the camera (constant -8,
/// slope -12, clamp -1e-4 when the device has `depthBiasClamp`). All four decals show as clean
/// rectangles. A dark rod just in front of the slanted wall crosses the lower decal: with the
/// clamp the bias stays far below the rod's distance and the rod hides the decal; without
/// the clamp (device lacking the feature) the slope term alone pulls the decal over the rod.
///
/// Layer item: depth-bias negation (constant, slope and clamp). Unnegated, the bias pushes
/// the decals away from the camera in reversed depth and they vanish behind their walls; an
/// unnegated clamp with negated factors no longer limits the bias, and the lower decal jumps
/// over the rod.
pub fn depth_bias() -> Scene {
    depth_bias_scene("depth-bias", false)
}

/// `depth-bias-dynamic`: the `depth-bias` scene with `VK_DYNAMIC_STATE_DEPTH_BIAS` and one
/// `vkCmdSetDepthBias` per decal, each decal with its own factors ([`DECAL_BIASES`]).
///
/// Layer item: depth-bias negation of the dynamic state; the image is wrong as in
/// `depth-bias` if it is missed.
pub fn depth_bias_dynamic() -> Scene {
    depth_bias_scene("depth-bias-dynamic", true)
}

fn depth_bias_scene(name: &'static str, dynamic: bool) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let (walls, decals) = bias_objects();
    let walls = b.nearest_first(&camera, walls);
    let decals: Vec<usize> = decals.into_iter().map(|o| b.object(o)).collect();
    b.pass(PassSpec::clear(1.0));
    let standard = b.pipeline(PipelineSpec::standard("standard", 0));
    let decal = b.pipeline(PipelineSpec {
        bias: if dynamic {
            Bias::Dynamic
        } else {
            Bias::Static(DECAL_BIAS)
        },
        ..test_only("decal", DepthTest::Static(Compare::Less))
    });
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.draw(&walls);
    b.step(Step::Bind(decal));
    for (&object, bias) in decals.iter().zip(DECAL_BIASES) {
        if dynamic {
            b.step(Step::SetDepthBias(bias));
        }
        b.step(Step::Draw(object));
    }
    b.step(Step::EndPass);
    b.finish(name, camera, None)
}

/// The depth bound of `depth-bounds`.
pub const BOUNDS_MAX: f32 = 0.975;

/// A clip-space rectangle `[x0, x1] x [y0, y1]` (Vulkan NDC, y down) at clip depth 0.5.
fn clip_rect(name: &'static str, [x0, y0, x1, y1]: [f64; 4], color: [f32; 4]) -> Object {
    Object {
        name,
        mesh: Mesh::rect_xy(
            (x0 + x1) / 2.0,
            (y0 + y1) / 2.0,
            (x1 - x0) / 2.0,
            (y1 - y0) / 2.0,
        ),
        model: DMat4::from_translation(DVec3::new(0.0, 0.0, 0.5)),
        color,
        space: Space::Clip,
    }
}

/// `depth-bounds` (needs the `depthBounds` feature; lavapipe lacks it): the overlap scene,
/// then full-height overlays with the depth test off and the depth bounds test on, which
/// paint only the pixels whose *stored* depth lies within the bounds: the left half with a
/// static [0, 0.975] pipeline (pale yellow: the near cube and the near ground, nothing far,
/// not the background), the right half with a pipeline whose bounds are dynamic
/// (`vkCmdSetDepthBounds`): [0, 0.975] on the top half (pale cyan), [0.97, 0.975] on the
/// bottom half (pink band on the ground).
///
/// Layer item: depth bounds [lo, hi] -> [1 - hi, 1 - lo], static and dynamic. Unmapped, the
/// reversed stored depths of far surfaces and of the background (0) fall inside [0, 0.975]
/// and the overlays paint the far half of the image instead of the near one.
pub fn depth_bounds() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let world = b.nearest_first(&camera, overlap_objects());
    let left = b.object(clip_rect(
        "static bounds overlay",
        [-1.0, -1.0, 0.0, 1.0],
        rgb8(255, 240, 150),
    ));
    let right_top = b.object(clip_rect(
        "dynamic bounds overlay",
        [0.0, -1.0, 1.0, 0.0],
        rgb8(150, 240, 255),
    ));
    let right_bottom = b.object(clip_rect(
        "dynamic bounds band",
        [0.0, 0.0, 1.0, 1.0],
        rgb8(255, 150, 220),
    ));
    b.pass(PassSpec::clear(1.0));
    let standard = b.pipeline(PipelineSpec::standard("standard", 0));
    let overlay = |name, bounds| PipelineSpec {
        bounds,
        ..test_only(name, DepthTest::Off)
    };
    let fixed = b.pipeline(overlay(
        "static bounds",
        Bounds::Static {
            min: 0.0,
            max: BOUNDS_MAX,
        },
    ));
    let dynamic = b.pipeline(overlay("dynamic bounds", Bounds::Dynamic));
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.draw(&world);
    b.step(Step::Bind(fixed));
    b.step(Step::Draw(left));
    b.step(Step::Bind(dynamic));
    b.step(Step::SetDepthBounds {
        min: 0.0,
        max: BOUNDS_MAX,
    });
    b.step(Step::Draw(right_top));
    b.step(Step::SetDepthBounds {
        min: 0.97,
        max: BOUNDS_MAX,
    });
    b.step(Step::Draw(right_bottom));
    b.step(Step::EndPass);
    b.finish("depth-bounds", camera, None)
}

/// `viewport-sky`: the overlap scene, then a full-screen sky quad (clip-space, identity MVP)
/// drawn with viewport depth range [1, 1] and LESS_OR_EQUAL without depth writes: the sky
/// fills only the background (above the ground's far edge), never over the objects.
///
/// Layer item: the viewport depth flip on the flip path (a hard-coded clip z no matrix
/// rewrite reaches), with the LESS_OR_EQUAL swap. Unflipped, the sky lands at reversed depth
/// 1, the nearest possible, and covers the whole image.
pub fn viewport_sky() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let world = b.nearest_first(&camera, overlap_objects());
    let sky = b.object(Object::full_screen("sky", rgb8(120, 180, 240)));
    b.pass(PassSpec::clear(1.0));
    let standard = b.pipeline(PipelineSpec::standard("standard", 0));
    let sky_pipeline = b.pipeline(PipelineSpec {
        viewport: Viewport::Static {
            min_depth: 1.0,
            max_depth: 1.0,
        },
        ..test_only("sky", DepthTest::Static(Compare::LessOrEqual))
    });
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.draw(&world);
    b.step(Step::Bind(sky_pipeline));
    b.step(Step::Draw(sky));
    b.step(Step::EndPass);
    b.finish("viewport-sky", camera, None)
}

/// The viewport depth ranges of `viewport-split`: (weapon, world, dynamic).
pub const SPLIT_RANGES: [[f32; 2]; 3] = [[0.0, 0.1], [0.1, 1.0], [0.5, 1.0]];

/// `viewport-split`: a first-person "weapon" (a long box in view space at the lower right,
/// 0.5 to 1.2 in front of the eye) drawn with viewport depth range [0, 0.1], the world
/// with [0.1, 1]: a lamp post 0.7 in front of the eye crosses the weapon on screen and, although
/// physically in front of most of it, is hidden by it. One floating cube (in front of the far
/// cube, against the sky) is drawn with a dynamic viewport (`vkCmdSetViewport`) of range
/// [0.5, 1]: squeezed toward the far plane, it ends up behind the far cube (which hides its
/// lower left) although it is physically in front.
///
/// Layer item: the viewport depth flip of static and dynamic viewports with partial ranges
/// ([a, b] -> [1 - a, 1 - b] on the flip path, [1 - b, 1 - a] with a rewritten projection).
/// Unflipped, the weapon's range becomes the far end of the reversed buffer (the post and the
/// world cover it) and the dynamic cube jumps in front of the far cube and the ground.
pub fn viewport_split() -> Scene {
    let camera = overlap_camera();
    let eye_to_world = camera.view().inverse();
    let mut b = Builder::default();
    let weapon = b.object(Object::world(
        "weapon",
        Mesh::cuboid(DVec3::new(0.035, 0.03, 0.35)),
        eye_to_world
            * DMat4::from_translation(DVec3::new(0.07, -0.09, -0.85))
            * DMat4::from_rotation_y(8f64.to_radians()),
        rgb8(60, 60, 70),
    ));
    // The post passes through the view-space point (0.1, -0.09, -0.7), vertical in the world.
    let post_point = eye_to_world.transform_point3(DVec3::new(0.1, -0.09, -0.7));
    let mut world_objects = overlap_objects();
    world_objects.push(Object::world(
        "lamp post",
        Mesh::cuboid(DVec3::new(0.02, 1.5, 0.02)),
        DMat4::from_translation(DVec3::new(post_point.x, 1.5, post_point.z)),
        rgb8(250, 250, 250),
    ));
    let world = b.nearest_first(&camera, world_objects);
    let squeezed = b.object(Object::world(
        "squeezed cube",
        Mesh::cuboid(DVec3::splat(0.35)),
        DMat4::from_translation(DVec3::new(-1.7, 1.95, -1.9)) * DMat4::from_rotation_y(0.5),
        rgb8(0, 230, 230),
    ));
    b.pass(PassSpec::clear(1.0));
    let ranged = |name, [min_depth, max_depth]: [f32; 2]| PipelineSpec {
        viewport: Viewport::Static {
            min_depth,
            max_depth,
        },
        ..PipelineSpec::standard(name, 0)
    };
    let weapon_pipeline = b.pipeline(ranged("weapon", SPLIT_RANGES[0]));
    let world_pipeline = b.pipeline(ranged("world", SPLIT_RANGES[1]));
    let dynamic = b.pipeline(PipelineSpec {
        viewport: Viewport::Dynamic,
        ..PipelineSpec::standard("dynamic viewport", 0)
    });
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(weapon_pipeline));
    b.step(Step::Draw(weapon));
    b.step(Step::Bind(world_pipeline));
    b.draw(&world);
    b.step(Step::Bind(dynamic));
    let [min_depth, max_depth] = SPLIT_RANGES[2];
    b.step(Step::SetViewport {
        min_depth,
        max_depth,
    });
    b.step(Step::Draw(squeezed));
    b.step(Step::EndPass);
    b.finish("viewport-split", camera, None)
}

/// `stencil` (d24-s8 and d32-s8 only): the render pass clears stencil to 0 (and depth to
/// 1.0). The ground and two cubes are drawn; then a portal rectangle standing behind the near
/// cube writes stencil 1 where it passes the depth test (LESS; no color, no depth writes), so
/// not where the near cube hides it; then a full-screen quad with stencil EQUAL 1 paints the
/// portal cyan, a cube behind the portal with EQUAL 1 shows only through it, and a long bar
/// with NOT_EQUAL 1 shows everywhere but through it (interrupted by the portal).
///
/// Layer item: the stencil part of the render-pass clear must stay untouched while the depth
/// part is flipped (and the mask's LESS swapped). A clear that touched the stencil (or a
/// stencil value written as 1 - 0) would paint the whole image cyan and hide the bar; an
/// unswapped LESS on the mask writes no stencil: no portal at all.
pub fn stencil() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let world: Vec<Object> = overlap_objects()
        .into_iter()
        .filter(|o| matches!(o.name, "ground" | "near cube" | "far cube"))
        .collect();
    let world = b.nearest_first(&camera, world);
    let portal = b.object(Object::world(
        "portal",
        Mesh::rect_xy(0.0, 0.0, 1.0, 0.85),
        DMat4::from_translation(DVec3::new(0.1, 1.05, 0.6)),
        rgb8(255, 255, 255),
    ));
    let inside = b.object(Object::full_screen("portal interior", rgb8(0, 200, 220)));
    let inside_cube = b.object(grounded_cube(
        "cube behind the portal",
        0.45,
        0.5,
        -0.6,
        0.5,
        rgb8(250, 210, 20),
    ));
    let bar = b.object(Object::world(
        "bar",
        Mesh::cuboid(DVec3::new(2.6, 0.12, 0.12)),
        DMat4::from_translation(DVec3::new(0.0, 1.2, 0.0)),
        rgb8(30, 200, 40),
    ));
    b.pass(PassSpec::clear(1.0));
    let standard = b.pipeline(PipelineSpec::standard("standard", 0));
    let stencil_test = |compare, on_pass| {
        Some(StencilTest {
            compare,
            reference: 1,
            on_pass,
        })
    };
    let mask = b.pipeline(PipelineSpec {
        color_write: false,
        stencil: stencil_test(Compare::Always, StencilWrite::Replace),
        ..test_only("stencil mask", DepthTest::Static(Compare::Less))
    });
    let fill_inside = b.pipeline(PipelineSpec {
        stencil: stencil_test(Compare::Equal, StencilWrite::Keep),
        ..test_only("inside fill", DepthTest::Off)
    });
    let inside_only = b.pipeline(PipelineSpec {
        stencil: stencil_test(Compare::Equal, StencilWrite::Keep),
        ..PipelineSpec::standard("inside only", 0)
    });
    let outside_only = b.pipeline(PipelineSpec {
        stencil: stencil_test(Compare::NotEqual, StencilWrite::Keep),
        ..PipelineSpec::standard("outside only", 0)
    });
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.draw(&world);
    for (pipeline, object) in [
        (mask, portal),
        (fill_inside, inside),
        (inside_only, inside_cube),
        (outside_only, bar),
    ] {
        b.step(Step::Bind(pipeline));
        b.step(Step::Draw(object));
    }
    b.step(Step::EndPass);
    b.finish("stencil", camera, None)
}

/// `secondary`: the overlap scene's draws recorded into two secondary command buffers
/// (RENDER_PASS_CONTINUE, inheritance naming the render pass, subpass 0 and the framebuffer;
/// each binds the pipeline itself), executed with one `vkCmdExecuteCommands` in a pass begun
/// with SECONDARY_COMMAND_BUFFERS contents. The image is exactly the overlap image.
///
/// Layer item: per-command-buffer state in secondaries (DESIGN.md pitfall 9): pipelines
/// bound and push constants written inside secondary command buffers must be handled like
/// primary ones. Missed, the secondaries' draws keep standard depth against a reversed clear
/// and compare: the occlusion order inverts (far cubes over near ones) or nothing draws.
pub fn secondary() -> Scene {
    let mut scene = overlap();
    scene.name = "secondary";
    let draws: Vec<Step> = (0..scene.objects.len()).map(Step::Draw).collect();
    let (first, second) = draws.split_at(2);
    let record = |draws: &[Step]| {
        let mut steps = vec![Step::Bind(0)];
        steps.extend_from_slice(draws);
        steps
    };
    scene.plan.steps = vec![
        Step::BeginPass(0),
        Step::ExecuteSecondaries(vec![record(first), record(second)], Recording::MainThread),
        Step::EndPass,
    ];
    scene
}

/// `subpasses`: the overlap objects in one render pass with two subpasses sharing the depth
/// attachment: subpass 0 (no color attachment) is a depth-only pre-pass with LESS, subpass 1
/// draws the same objects in color with EQUAL (depth read-write layout, writes off); a
/// subpass dependency orders subpass 0's depth writes before subpass 1's tests. Subpass 1
/// draws farthest first, so that where two surfaces tie the pre-pass's choice wins: the image
/// is exactly the overlap image.
///
/// Layer item: compare ops and clear values in a multi-subpass render pass (the depth
/// attachment is reversed for both subpasses). A layer that handled only subpass 0, or only
/// single-subpass passes, leaves EQUAL comparing against unmatched values: nothing draws.
pub fn subpasses() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    b.pass(PassSpec {
        kind: PassKind::DepthPrepassSubpasses,
        ..PassSpec::clear(1.0)
    });
    let prepass = b.pipeline(PipelineSpec {
        program: Program::DepthOnly,
        color_write: false,
        ..PipelineSpec::standard("depth pre-pass", 0)
    });
    let color = b.pipeline(PipelineSpec {
        subpass: 1,
        ..test_only("equal", DepthTest::Static(Compare::Equal))
    });
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(prepass));
    b.draw(&objects);
    b.step(Step::NextSubpass);
    b.step(Step::Bind(color));
    // Farthest first: where surfaces tie exactly, the one the LESS pre-pass kept is drawn
    // last, so the image is exactly the overlap image.
    let reversed: Vec<usize> = objects.iter().rev().copied().collect();
    b.draw(&reversed);
    b.step(Step::EndPass);
    b.finish("subpasses", camera, None)
}

/// `dynamic-rendering`: the overlap scene drawn with `vkCmdBeginRendering` (depth cleared to
/// 1.0 through `VkRenderingAttachmentInfo`, pipelines made with `VkPipelineRenderingCreateInfo`),
/// then a second `vkCmdBeginRendering` that loads color and depth and draws an orange cube
/// partly hidden by the near cube and a cyan pillar partly hidden by the slab.
///
/// Layer item: the clear value of dynamic rendering's attachment info. Unflipped, the first
/// rendering's reversed test passes nowhere: nothing draws in either rendering.
pub fn dynamic_rendering() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let first = b.nearest_first(&camera, overlap_objects());
    let second = b.nearest_first(
        &camera,
        vec![
            grounded_cube("orange cube", 0.35, -0.2, 1.0, 0.7, rgb8(255, 140, 0)),
            Object::world(
                "pillar",
                Mesh::cuboid(DVec3::new(0.18, 1.4, 0.18)),
                DMat4::from_translation(DVec3::new(1.6, 1.35, -1.6)),
                rgb8(0, 230, 230),
            ),
        ],
    );
    let dynamic = |depth, load_color| PassSpec {
        target: Target::Main,
        kind: PassKind::DynamicRendering,
        depth,
        load_color,
        multisample: None,
    };
    let clear = b.pass(dynamic(DepthLoad::Clear(1.0), false));
    let load = b.pass(dynamic(DepthLoad::Load, true));
    let standard = b.pipeline(PipelineSpec::standard("standard", clear));
    b.step(Step::BeginPass(clear));
    b.step(Step::Bind(standard));
    b.draw(&first);
    b.step(Step::EndPass);
    b.step(Step::BeginPass(load));
    b.step(Step::Bind(standard));
    b.draw(&second);
    b.step(Step::EndPass);
    b.finish("dynamic-rendering", camera, None)
}

/// The light of `shadow-map`: above the scene, behind it to the left, looking down at it
/// (shadows fall toward the camera and to the right).
pub fn shadow_light() -> Light {
    Light {
        eye: DVec3::new(-5.0, 10.0, -6.0),
        target: DVec3::new(0.0, 0.0, 0.0),
        up: DVec3::Y,
        half_extent: 8.0,
        near: 2.0,
        far: 25.0,
    }
}

/// The light-space depth bias of the shadow pass (standard, positive: away from the light).
pub const SHADOW_BIAS: DepthBias = DepthBias {
    constant: 1.25,
    slope: 1.75,
    clamp: 0.0,
};

/// `shadow-map`: an orthographic shadow pass (light above, looking down) renders the cubes,
/// a pillar and the ground into a separate D32_SFLOAT shadow map (DEPTH_STENCIL_ATTACHMENT |
/// SAMPLED, cleared to 1.0, LESS, a standard positive depth bias), then the main pass (the
/// chosen depth format, perspective camera, LESS) draws the same objects with
/// `shadow_receiver.frag`, which samples the map through a comparison sampler
/// (`compareEnable`, LESS_OR_EQUAL) and darkens shadowed surfaces: long shadows fall on the
/// ground away from the light.
///
/// Layer item: observable depth images stay native. The shadow map is SAMPLED, so its clear
/// value, compare op, depth bias and viewport must be left alone while the main pass is
/// reversed. Reversing it hands the shader reversed stored depths: the LESS_OR_EQUAL compare
/// against standard references then shadows everything (or nothing); negating its bias
/// brings back shadow acne (dark stripes on lit surfaces).
pub fn shadow_map() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let mut objects = overlap_objects();
    objects.retain(|o| o.name != "slab");
    objects.push(Object::world(
        "pillar",
        Mesh::cuboid(DVec3::new(0.15, 0.9, 0.15)),
        DMat4::from_translation(DVec3::new(-1.55, 0.85, 2.2)),
        rgb8(250, 210, 20),
    ));
    let objects = b.nearest_first(&camera, objects);
    let shadow = b.pass(PassSpec {
        target: Target::Shadow,
        ..PassSpec::clear(1.0)
    });
    let main = b.pass(PassSpec::clear(1.0));
    let caster = b.pipeline(PipelineSpec {
        program: Program::DepthOnly,
        color_write: false,
        bias: Bias::Static(SHADOW_BIAS),
        ..PipelineSpec::standard("shadow caster", shadow)
    });
    let receiver = b.pipeline(PipelineSpec {
        program: Program::ShadowReceiver,
        ..PipelineSpec::standard("shadow receiver", main)
    });
    for (pass, pipeline) in [(shadow, caster), (main, receiver)] {
        b.step(Step::BeginPass(pass));
        b.step(Step::Bind(pipeline));
        b.draw(&objects);
        b.step(Step::EndPass);
    }
    b.finish("shadow-map", camera, Some(shadow_light()))
}

/// `shadow-map-secondaries`: `shadow-map` with each pass's draws recorded into two secondaries
/// on two threads, the second of each inheriting the render pass and subpass without the
/// framebuffer (which the inheritance info may leave null).
///
/// Layer item: a secondary without a framebuffer knows only its render pass and depth format,
/// and the sampled (native) shadow map and the reversed main attachment share D32: guessing by
/// format draws the shadow casters reversed into the native map, so no shadow lands. The render
/// must be `shadow-map`'s.
pub fn shadow_map_secondaries() -> Scene {
    let mut scene = shadow_map();
    scene.name = "shadow-map-secondaries";
    let mut steps = Vec::new();
    let mut lists: Vec<Vec<Step>> = Vec::new();
    for step in std::mem::take(&mut scene.plan.steps) {
        match step {
            Step::BeginPass(_) => steps.push(step),
            Step::Bind(_) => lists = vec![vec![step.clone()], vec![step]],
            Step::Draw(_) => {
                let shortest = if lists[0].len() <= lists[1].len() {
                    0
                } else {
                    1
                };
                lists[shortest].push(step);
            }
            Step::EndPass => {
                steps.push(Step::ExecuteSecondaries(
                    std::mem::take(&mut lists),
                    Recording::ThreadPerSecondaryOddWithoutFramebuffer,
                ));
                steps.push(step);
            }
            other => unreachable!("shadow-map records no {other:?}"),
        }
    }
    scene.plan.steps = steps;
    scene
}

/// The sample count of the multisampled scenes.
pub const MSAA_SAMPLES: u32 = 4;

/// `msaa-resolve`: the overlap scene (its objects, camera and drawing order) rendered at 4x
/// MSAA in a render pass made with `vkCreateRenderPass2`: one subpass draws into a transient
/// 4x color attachment and a transient 4x depth attachment (DEPTH_STENCIL_ATTACHMENT |
/// TRANSIENT_ATTACHMENT only: never read back, never copied), cleared to 1.0, LESS, pipelines
/// rasterizing 4 samples; at the end of the subpass the color is resolved
/// (`pResolveAttachments`) into the main color image and the depth through
/// `VkSubpassDescriptionDepthStencilResolve` into the main depth image (the one read back),
/// with `--depth-resolve`'s mode (default SAMPLE_ZERO; stencil NONE where the device allows
/// it, else the depth mode). The color image is the overlap image with antialiased edges.
///
/// Layer item: depth resolves of `vkCreateRenderPass2` render passes. The 4x image is not
/// observable, so the layer may reverse it; the read-back main image stays native by
/// default, and a reversed attachment resolved into a native one hands it reversed values
/// unless the layer keeps the 4x image native. Missed, the colors stay right but the depth
/// read back is 1 - D: `depth.png` shows the background (cleared to 1.0, resolved as 0) as
/// covered and the near cube dimmest. With both images reversed
/// (`reverse_observable = copies`), MIN and MAX must be swapped: unswapped, every
/// silhouette pixel of the depth image takes its farthest sample instead of its nearest (or
/// the reverse), so the depth silhouettes shrink (grow) by a pixel against the color image.
pub fn msaa_resolve() -> Scene {
    msaa_scene("msaa-resolve", PassKind::RenderPass)
}

/// `msaa-resolve-dynamic`: [`msaa_resolve`] with dynamic rendering: `vkCmdBeginRendering`
/// whose depth `VkRenderingAttachmentInfo` (and stencil one, for formats with stencil) names
/// the 4x depth view with `resolveMode` and the main depth image as `resolveImageView`, and
/// whose color attachment resolves (AVERAGE) into the main color image likewise.
///
/// Layer item: the resolve mode and resolve image of dynamic rendering's depth attachment
/// info. Missed, the same wrong depth image as [`msaa_resolve`]'s.
pub fn msaa_resolve_dynamic() -> Scene {
    msaa_scene("msaa-resolve-dynamic", PassKind::DynamicRendering)
}

/// The overlap scene (objects nearest first, one pass, the standard pipeline) with its pass
/// made a 4x multisampled one of `kind`, depth cleared to 1.0 and resolved with SAMPLE_ZERO
/// (`--depth-resolve` changes it).
fn msaa_scene(name: &'static str, kind: PassKind) -> Scene {
    let mut scene = overlap();
    scene.name = name;
    scene.plan.passes[0] = PassSpec {
        kind,
        multisample: Some(Multisample {
            samples: MSAA_SAMPLES,
            depth_resolve: ResolveMode::SampleZero,
        }),
        ..PassSpec::clear(1.0)
    };
    scene
}

/// A rectangle facing the eye of `camera` at view distance `distance` (so its depth is the same
/// at every pixel) that covers `[x0, x1] x [y0, y1]` of Vulkan NDC (y down) at aspect 1.
fn card(
    camera: &Camera,
    name: &'static str,
    distance: f64,
    [x0, y0, x1, y1]: [f64; 4],
    color: [f32; 4],
) -> Object {
    // NDC x = x_view / (t * distance), NDC y = -y_view / (t * distance).
    let scale = (camera.fov_y / 2.0).tan() * distance;
    Object::world(
        name,
        Mesh::rect_xy(
            scale * (x0 + x1) / 2.0,
            -scale * (y0 + y1) / 2.0,
            scale * (x1 - x0) / 2.0,
            scale * (y1 - y0) / 2.0,
        ),
        camera.view().inverse() * DMat4::from_translation(DVec3::new(0.0, 0.0, -distance)),
        color,
    )
}

/// `frag-depth`: three cards facing the eye (each at one depth), drawn in this order with LESS
/// and depth writes:
/// - a blue far wall (view distance 8, depth 0.98849; standard pipeline) on the left;
/// - a red card across the middle (distance 3, depth D = 0.96763), the nearest surface, drawn
///   with `frag_depth.frag` ([`Program::FragDepth`]): it stores 0.5 + 0.5 * D = 0.98382,
///   still in front of the wall (it covers the wall's upper right) and of the clear (1.0: its
///   upper band and its middle cover nothing else);
/// - a green card (distance 4.5, depth 0.97876; standard pipeline) on the right, geometrically
///   behind the red card but in front of its pushed-back depth: it passes against what the
///   red card stored and shows over the red card's lower right.
///
/// Layer item: fragment shaders that write `FragDepth` and read `gl_FragCoord.z`. Into a
/// reversed attachment the rewritten shader must read the standard depth (1 - z) and store the
/// reversal of what it computes (1 - x = 0.01618, between the green card's 1 - 0.97876 =
/// 0.02124 and the wall's 0.01151). Stores left unflipped (0.98382), or the reversed depth
/// read as it is (the shader computes 0.5 + 0.5 * 0.03237 = 0.51618, stored flipped as
/// 0.48382 or as it is), all land near the eye: the red card covers the green one where they
/// overlap. A FragDepth draw left with LESS fails against the reversed clear (0): the red card
/// vanishes, the wall and the background show through. Where the red card is alone, the depth
/// read back is the stored FragDepth value itself.
pub fn frag_depth() -> Scene {
    frag_depth_built("frag-depth", false)
}

/// `frag-depth-library` (needs `VK_EXT_graphics_pipeline_library`): [`frag_depth`] with every
/// pipeline built from four libraries linked together, as in [`pipeline_library`].
///
/// Layer item: a fragment shader library that computes with depth. The layer must give the
/// fragment shader library a variant with the rewritten shader and bind, for draws into a
/// reversed attachment, a variant of the linked pipeline that links it; a layer that links
/// the application's library shows what [`frag_depth`] shows with the shader untouched.
pub fn frag_depth_library() -> Scene {
    frag_depth_built("frag-depth-library", true)
}

/// The `frag-depth` scene named `name`, its pipelines built from libraries or not.
fn frag_depth_built(name: &'static str, libraries: bool) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let wall = b.object(card(
        &camera,
        "far wall",
        8.0,
        [-0.85, -0.2, -0.15, 0.7],
        rgb8(40, 80, 240),
    ));
    let pushed = b.object(card(
        &camera,
        "pushed card",
        3.0,
        [-0.5, -0.6, 0.5, 0.3],
        rgb8(230, 30, 30),
    ));
    let middle = b.object(card(
        &camera,
        "middle card",
        4.5,
        [0.15, -0.2, 0.85, 0.7],
        rgb8(30, 200, 40),
    ));
    b.pass(PassSpec::clear(1.0));
    let standard = b.pipeline(PipelineSpec {
        libraries,
        ..PipelineSpec::standard("standard", 0)
    });
    let frag_depth = b.pipeline(PipelineSpec {
        program: Program::FragDepth,
        libraries,
        ..PipelineSpec::standard("frag depth", 0)
    });
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.step(Step::Draw(wall));
    b.step(Step::Bind(frag_depth));
    b.step(Step::Draw(pushed));
    b.step(Step::Bind(standard));
    b.step(Step::Draw(middle));
    b.step(Step::EndPass);
    b.finish(name, camera, None)
}

/// A rectangle `[x ± half_width] x [y ± half_height]` on the +z face of `cube` (a
/// [`grounded_cube`] of half size `half`): the face's plane in the cube's own model space
/// (local z = `half`, the very f32 value of the face's vertices) with the cube's model matrix,
/// so exactly coplanar with the face.
fn face_decal(
    name: &'static str,
    cube: &Object,
    half: f64,
    [x, y, half_width, half_height]: [f64; 4],
    color: [f32; 4],
) -> Object {
    Object {
        name,
        mesh: Mesh::rect_xy(x, y, half_width, half_height).translated(DVec3::new(0.0, 0.0, half)),
        color,
        ..cube.clone()
    }
}

/// The half sizes of the overlap scene's near and middle cubes (see `overlap_objects`).
const NEAR_CUBE_HALF: f64 = 0.5;
/// See [`NEAR_CUBE_HALF`].
const MIDDLE_CUBE_HALF: f64 = 0.75;

/// `pipeline-library` (needs `VK_EXT_graphics_pipeline_library`): every pipeline is built
/// from four libraries (vertex input interface, pre-rasterization shaders, fragment shader,
/// fragment output interface; each given the render pass and subpass where it needs them)
/// linked into the pipeline bound, with all depth state static and where the extension puts
/// it: the viewport and the rasterization state (depth bias) in the pre-rasterization
/// library, the depth-stencil state (compare op, test and write) in the fragment shader
/// library. One render pass (depth cleared to 1.0) draws:
/// - the overlap objects with LESS and depth writes (the nearest wins: the red cube in front
///   of the green one, the slab cutting the green cube, the blue cube behind);
/// - two decals coplanar with the +z faces of the red and green cubes (same model matrix,
///   the face's own plane), with LESS, no depth writes and the static bias of `depth-bias`
///   (constant -8, slope -12, clamp -1e-4 when the device has `depthBiasClamp`): a white
///   square on the red cube, a cyan band on the green cube whose left end passes behind the
///   red cube, which hides it there (the red cube is in front by far more than the bias);
/// - a full-screen sky quad (clip depth 0.5) with viewport depth range [1, 1] and
///   LESS_OR_EQUAL without depth writes: it fills the background above the ground only.
///
/// Layer item: depth state carried by pipeline libraries. The layer must change the libraries
/// as it changes ordinary pipelines (swap the compare ops in the fragment shader library;
/// negate the bias and flip the viewport depth range in the pre-rasterization library, as its
/// mode wants): the linked create info carries no depth state at all. A layer that passes
/// library pipelines through untouched into a reversed depth buffer (cleared to 0) leaves
/// LESS and LESS_OR_EQUAL failing against it at every pixel: the whole image is the clear
/// color. With the fragment shader library handled but not the pre-rasterization one: the
/// unflipped [1, 1] sky lands at reversed depth 1, the nearest, and covers the whole image;
/// an unnegated bias pushes the decals behind their faces (they vanish: plain red and green
/// faces, the white square and cyan band gone); on the flip path (viewport flipped for a
/// standard projection) a missed flip also leaves standard depths tested with GREATER, so the
/// farthest surface wins (the ground over the cubes).
pub fn pipeline_library() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = overlap_objects();
    let cube = |name: &str| {
        objects
            .iter()
            .find(|o| o.name == name)
            .expect("overlap has the cube")
            .clone()
    };
    let (near, middle) = (cube("near cube"), cube("middle cube"));
    let world = b.nearest_first(&camera, objects);
    let decals = [
        face_decal(
            "near cube decal",
            &near,
            NEAR_CUBE_HALF,
            [0.0, 0.05, 0.25, 0.25],
            rgb8(240, 240, 240),
        ),
        face_decal(
            "middle cube decal",
            &middle,
            MIDDLE_CUBE_HALF,
            [-0.1, 0.25, 0.55, 0.15],
            rgb8(0, 230, 230),
        ),
    ]
    .map(|o| b.object(o));
    let sky = b.object(Object::full_screen("sky", rgb8(120, 180, 240)));
    b.pass(PassSpec::clear(1.0));
    let library = |spec: PipelineSpec| PipelineSpec {
        libraries: true,
        ..spec
    };
    let standard = b.pipeline(library(PipelineSpec::standard("standard", 0)));
    let decal = b.pipeline(library(PipelineSpec {
        bias: Bias::Static(DECAL_BIAS),
        ..test_only("decal", DepthTest::Static(Compare::Less))
    }));
    let sky_pipeline = b.pipeline(library(PipelineSpec {
        viewport: Viewport::Static {
            min_depth: 1.0,
            max_depth: 1.0,
        },
        ..test_only("sky", DepthTest::Static(Compare::LessOrEqual))
    }));
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.draw(&world);
    b.step(Step::Bind(decal));
    b.draw(&decals);
    b.step(Step::Bind(sky_pipeline));
    b.step(Step::Draw(sky));
    b.step(Step::EndPass);
    b.finish("pipeline-library", camera, None)
}

/// The overlap objects with their model matrices applied in `space`.
fn overlap_objects_in(space: Space) -> Vec<Object> {
    overlap_objects()
        .into_iter()
        .map(|o| Object { space, ..o })
        .collect()
}

/// `projection-only`: the overlap scene with the projection P alone in the push constants:
/// each object's vertices are transformed to view space on the CPU (V * M in f64, rounded once
/// to f32, [`Space::ViewBaked`]) and `scene.vert` computes `P * position`.
///
/// Layer item: the precise path on a bare projection (the matrix the layer classifies is P
/// itself: no view or model part folded in).
pub fn projection_only() -> Scene {
    Scene::new(
        "projection-only",
        overlap_camera(),
        overlap_objects_in(Space::ViewBaked),
    )
}

/// The camera of `view-projection`: eye (4, 3, 12) looking far down -z, near 0.1, far 1000.
pub fn far_camera() -> Camera {
    Camera {
        eye: DVec3::new(4.0, 3.0, 12.0),
        target: DVec3::new(0.0, 4.0, -100.0),
        far: 1000.0,
        ..overlap_camera()
    }
}

/// `view-projection`: P * V in the push constants, the vertices in world space (each model
/// matrix applied on the CPU, [`Space::WorldBaked`]); and a scene reaching far: boxes at view
/// distances of about 5, 30, 120 and 430 overlapping on screen, in front of a wall 860 away,
/// with near 0.1 and far 1000. Nothing floats near anything else (the closest depths of two
/// surfaces at any pixel differ by far more than standard D32's resolution out there), so the
/// image is the same whichever way depth is stored.
///
/// Layer item: the precise path on a view-projection matrix (a translated camera folded into
/// the projection); far depths are where standard and flip-path storage lose their precision
/// (1 - D there is about 1e-4, one float32 step near 1 is 6e-8), which the precise tests
/// measure.
pub fn view_projection() -> Scene {
    let boxed = |name, half: DVec3, at: DVec3, yaw: f64, color| Object {
        name,
        mesh: Mesh::cuboid(half),
        model: DMat4::from_translation(at) * DMat4::from_rotation_y(yaw),
        color,
        space: Space::WorldBaked,
    };
    let objects = vec![
        boxed(
            "near box",
            DVec3::splat(0.6),
            DVec3::new(3.3, 2.2, 7.0),
            0.5,
            rgb8(230, 30, 30),
        ),
        boxed(
            "middle box",
            DVec3::new(2.5, 2.0, 2.5),
            DVec3::new(1.5, 3.5, -17.0),
            0.3,
            rgb8(30, 200, 40),
        ),
        boxed(
            "far box",
            DVec3::splat(9.0),
            DVec3::new(-16.0, 6.0, -105.0),
            0.7,
            rgb8(40, 80, 240),
        ),
        boxed(
            "distant tower",
            DVec3::new(15.0, 60.0, 15.0),
            DVec3::new(40.0, 20.0, -420.0),
            0.2,
            rgb8(250, 210, 20),
        ),
        Object {
            name: "horizon wall",
            mesh: Mesh::rect_xy(0.0, 0.0, 700.0, 450.0),
            model: DMat4::from_translation(DVec3::new(0.0, 0.0, -850.0)),
            color: rgb8(150, 60, 170),
            space: Space::WorldBaked,
        },
    ];
    Scene::new("view-projection", far_camera(), objects)
}

/// `model-view-projection-pair`: the overlap scene drawn with `mvp_pair.vert`: push constants
/// `{ mat4 model @0; mat4 view_proj @64 }` and `gl_Position = view_proj * (model * position)`
/// (the color from a uniform buffer: the two matrices fill the 128 bytes lavapipe allows).
///
/// Layer item: only the outermost matrix of the chain is a projection. The layer must rewrite
/// `view_proj` (bytes 64..128) and leave `model` alone: an affine model matrix classifies as
/// orthographic, and rewriting it too would break the image.
pub fn model_view_projection_pair() -> Scene {
    let mut scene = Scene::new(
        "model-view-projection-pair",
        overlap_camera(),
        overlap_objects(),
    );
    scene.plan.pipelines[0].program = Program::MvpPair;
    scene
}

/// `row-major`: the overlap scene drawn with HLSL-style shaders: the near, slab and ground
/// objects with `row_major.vert` (the MVP in a `RowMajor` push-constant member), the others
/// with `row_vector.vert` (`position * M`); both read the MVP's rows from memory, so the CPU
/// pushes the transpose of what `overlap` pushes.
///
/// Layer item: storage order. The layer must read (and write back) the projection by rows
/// for both shaders; read as columns, the matrix is not a projection at all.
pub fn row_major() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    b.pass(PassSpec::clear(1.0));
    let rows = b.pipeline(PipelineSpec {
        program: Program::RowMajor,
        ..PipelineSpec::standard("row-major mvp", 0)
    });
    let vector = b.pipeline(PipelineSpec {
        program: Program::RowVector,
        ..PipelineSpec::standard("row-vector mvp", 0)
    });
    b.step(Step::BeginPass(0));
    for (pipeline, parity) in [(rows, 0), (vector, 1)] {
        b.step(Step::Bind(pipeline));
        let some: Vec<usize> = objects
            .iter()
            .enumerate()
            .filter(|(i, _)| i % 2 == parity)
            .map(|(_, &o)| o)
            .collect();
        b.draw(&some);
    }
    b.step(Step::EndPass);
    b.finish("row-major", camera, None)
}

/// `opengl-depth` (needs `VK_EXT_depth_clip_control`): the overlap scene with an
/// OpenGL-convention projection (glm without `GLM_FORCE_DEPTH_ZERO_TO_ONE`: z_ndc = -1 at
/// near, 1 at far) and pipelines made with `negativeOneToOne`, so the stored depth is
/// (z_ndc + 1) / 2: the same values as `overlap`'s.
///
/// Layer item: the depth convention of the pipeline (DESIGN.md pitfall 8): the projection's
/// visible range must be recovered under [-1, 1], and the rewritten matrix must stay in it.
/// Read as a [0, 1] projection its near plane lands at about 0.05 and the reversal is wrong.
pub fn opengl_depth() -> Scene {
    let camera = Camera {
        projection: Projection::OpenGl,
        ..overlap_camera()
    };
    let mut scene = Scene::new("opengl-depth", camera, overlap_objects());
    scene.plan.pipelines[0].negative_one_to_one = true;
    scene
}

/// `already-reversed`: an application that already renders reversed, as Unreal, Godot 4.3+ or
/// Bevy do: the overlap scene with a complementary projection (depth 1 at near, 0 at far),
/// depth cleared to 0 and compare GREATER.
///
/// Layer item: leave it alone (DESIGN.md pitfall 7). Reversing it again (flipping its clear,
/// compare op or projection) renders nothing or the far objects in front; the render must be
/// bit-identical to one without the layer.
pub fn already_reversed() -> Scene {
    let camera = Camera {
        projection: Projection::Reversed,
        ..overlap_camera()
    };
    let mut scene = Scene::new("already-reversed", camera, overlap_objects());
    scene.plan.passes[0] = PassSpec::clear(0.0);
    scene.plan.pipelines[0].depth_test = DepthTest::Static(Compare::Greater);
    scene
}

/// `push-partial`: push constants updated in parts between draws, each object still drawn with
/// a complete, known MVP and color (the unit tests replay the pushes byte by byte):
/// - the ground and the red cube push everything;
/// - the yellow lid shares the red cube's model matrix: only its color is pushed (bytes
///   64..80);
/// - the yellow cube behind is the red cube moved along its own z: only the MVP's last column
///   (the translation, bytes 48..64) is pushed, and it keeps the lid's color;
/// - the green cube pushes its MVP and color in two calls split inside the matrix (bytes 0..32
///   and 32..80);
/// - the blue pillar through it has the green cube's translation and its own rotation: its
///   first three columns (0..48) and its color (64..80) are pushed, the last column stays.
///
/// Layer item: `vkCmdPushConstants` calls that cover part of the projection, or none of it.
/// The layer must keep the application's bytes per command buffer and rewrite the whole
/// matrix from them at each draw; rewriting only the pushed bytes, or classifying a partial
/// matrix, leaves a mixed standard/reversed matrix (objects vanish or land at wrong depths).
pub fn push_partial() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let ground = overlap_objects()
        .into_iter()
        .find(|o| o.name == "ground")
        .expect("overlap has a ground");
    let red = grounded_cube("red cube", 0.45, -1.3, 1.2, 0.3, rgb8(230, 30, 30));
    let lid = Object {
        name: "lid",
        mesh: Mesh::cuboid(DVec3::new(0.3, 0.08, 0.3)).translated(DVec3::new(0.0, 0.5, 0.0)),
        color: rgb8(250, 210, 20),
        ..red.clone()
    };
    let moved = Object {
        name: "moved cube",
        model: red.model * DMat4::from_translation(DVec3::new(-0.9, 0.0, -2.0)),
        color: lid.color,
        ..red.clone()
    };
    let green = grounded_cube("green cube", 0.5, 1.3, 0.9, -0.4, rgb8(30, 200, 40));
    let pillar = Object {
        name: "pillar",
        mesh: Mesh::cuboid(DVec3::new(0.2, 0.85, 0.2)),
        model: green.model * DMat4::from_rotation_y(0.7),
        color: rgb8(40, 80, 240),
        ..green.clone()
    };
    let [ground, red, lid, moved, green, pillar] =
        [ground, red, lid, moved, green, pillar].map(|o| b.object(o));
    b.pass(PassSpec::clear(1.0));
    let standard = b.pipeline(PipelineSpec::standard("standard", 0));
    let push = |object, offset, size| Step::Push {
        object,
        offset,
        size,
    };
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.draw(&[ground, red]);
    for step in [
        push(lid, 64, 16),
        Step::DrawPushed(lid),
        push(moved, 48, 16),
        Step::DrawPushed(moved),
        push(green, 0, 32),
        push(green, 32, 48),
        Step::DrawPushed(green),
        push(pillar, 0, 48),
        push(pillar, 64, 16),
        Step::DrawPushed(pillar),
    ] {
        b.step(step);
    }
    b.step(Step::EndPass);
    b.finish("push-partial", camera, None)
}

/// `threads`: the overlap scene recorded on four threads at once (`std::thread::scope`), each
/// with its own command pool created on that thread and one secondary command buffer
/// (RENDER_PASS_CONTINUE, inheriting the render pass) that binds the geometry, a pipeline with
/// a dynamic viewport, sets the viewport and pushes its objects' constants itself; one primary
/// executes the four.
///
/// Layer item: multi-threaded recording (DESIGN.md pitfall 9): per-command-buffer state
/// (pipeline, viewport, push constants) recorded concurrently, objects created on several
/// threads; the image and depth must be exactly `overlap`'s.
pub fn threads() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    b.pass(PassSpec::clear(1.0));
    let pipeline = b.pipeline(PipelineSpec {
        viewport: Viewport::Dynamic,
        ..PipelineSpec::standard("dynamic viewport", 0)
    });
    let lists = (0..THREADS)
        .map(|thread| {
            let mut steps = vec![
                Step::Bind(pipeline),
                Step::SetViewport {
                    min_depth: 0.0,
                    max_depth: 1.0,
                },
            ];
            steps.extend(
                objects
                    .iter()
                    .skip(thread)
                    .step_by(THREADS)
                    .map(|&o| Step::Draw(o)),
            );
            steps
        })
        .collect();
    b.step(Step::BeginPass(0));
    b.step(Step::ExecuteSecondaries(
        lists,
        Recording::ThreadPerSecondary,
    ));
    b.step(Step::EndPass);
    b.finish("threads", camera, None)
}

/// The recording threads of `threads`.
pub const THREADS: usize = 4;

/// The camera of `lit-mvp`: eye (0.6, 2.1, 7.4) looking at (-0.2, 1.0, -4.0), 45 degrees,
/// near 0.1, far 100.
pub fn lit_camera() -> Camera {
    Camera {
        eye: DVec3::new(0.6, 2.1, 7.4),
        target: DVec3::new(-0.2, 1.0, -4.0),
        ..overlap_camera()
    }
}

/// One box of `lit-mvp`.
struct LitBox {
    name: &'static str,
    /// Half extents.
    half: [f64; 3],
    /// NDC center (x, y) at aspect 1 (y down).
    at: [f64; 2],
    /// View distance w of the center.
    distance: f64,
    /// (yaw, pitch, roll), radians, in the camera's frame.
    turn: [f64; 3],
    color: [u8; 3],
}

/// The boxes of `lit-mvp`. Their view-distance ranges are disjoint with margins of 4 % and
/// more (checked by a unit test); the wall fills the whole image behind them.
const LIT_BOXES: [LitBox; 6] = [
    LitBox {
        name: "red box",
        half: [0.45, 0.35, 0.4],
        at: [-0.45, 0.3],
        distance: 4.0,
        turn: [0.6, 0.35, 0.0],
        color: [200, 70, 60],
    },
    LitBox {
        name: "green box",
        half: [0.7, 0.55, 0.6],
        at: [0.4, 0.25],
        distance: 6.3,
        turn: [-0.5, 0.2, 0.3],
        color: [70, 170, 80],
    },
    LitBox {
        name: "blue slab",
        half: [1.3, 0.45, 0.8],
        at: [-0.1, -0.3],
        distance: 9.4,
        turn: [0.3, -0.4, 0.15],
        color: [70, 100, 210],
    },
    LitBox {
        name: "yellow cube",
        half: [1.1, 1.1, 1.1],
        at: [0.5, -0.45],
        distance: 13.8,
        turn: [0.8, 0.5, -0.2],
        color: [210, 180, 60],
    },
    LitBox {
        name: "cyan tower",
        half: [1.4, 2.0, 1.0],
        at: [-0.55, -0.4],
        distance: 19.0,
        turn: [-0.7, 0.1, 0.25],
        color: [60, 180, 190],
    },
    LitBox {
        name: "wall",
        half: [20.0, 14.0, 0.5],
        at: [0.0, 0.0],
        distance: 28.0,
        turn: [0.15, -0.1, 0.0],
        color: [150, 140, 130],
    },
];

/// `lit-mvp`: five boxes of several sizes and orientations at view distances 4 to 19 (each in
/// a depth range of its own: no depth-precision stress) in front of a wall filling the image,
/// drawn nearest first with [`Program::LitMvp`] (back faces culled): the push constants are
/// `scene.vert`'s (`{ mat4 mvp @0; vec4 color @64 }`, 80 bytes, each box its own P * V * M),
/// and the vertex shader uses the clip position `pos = mvp * p` both for `gl_Position` and
/// for the lighting (view vector `-pos.xyz`, face normal from its screen-space derivatives,
/// a fixed light, diffuse and a specular highlight on the color).
///
/// Layer item: where the reversal is applied (DESIGN.md section 2, issue #14). Rewriting the
/// pushed matrix's depth row changes `pos.z`, so the view vector, the normals and the
/// highlights, and the colors with them (the unit tests compute by how much); rewriting only
/// the store to `Position` leaves every color as it is natively: the render through the layer
/// must equal the native one in every mode.
pub fn lit_mvp() -> Scene {
    let camera = lit_camera();
    let view_to_world = camera.view().inverse();
    let t = (camera.fov_y / 2.0).tan();
    let objects = LIT_BOXES
        .iter()
        .map(|b| {
            let ([x, y], w, [yaw, pitch, roll]) = (b.at, b.distance, b.turn);
            let center = DVec3::new(x * t * w, -y * t * w, -w);
            Object::world(
                b.name,
                Mesh::cuboid(DVec3::from_array(b.half)),
                view_to_world
                    * DMat4::from_translation(center)
                    * DMat4::from_rotation_y(yaw)
                    * DMat4::from_rotation_x(pitch)
                    * DMat4::from_rotation_z(roll),
                rgb8(b.color[0], b.color[1], b.color[2]),
            )
        })
        .collect();
    let mut scene = Scene::new("lit-mvp", camera, objects);
    scene.plan.pipelines[0] = PipelineSpec {
        program: Program::LitMvp,
        cull_back_faces: true,
        ..PipelineSpec::standard("lit", 0)
    };
    scene
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::View;
    use clap::ValueEnum;
    use glam::DVec4;

    const ASPECT: f64 = 1.0;

    fn all() -> Vec<Scene> {
        SceneId::value_variants()
            .iter()
            .map(|id| id.build())
            .collect()
    }

    fn find(scene: &Scene, name: &str) -> usize {
        scene
            .objects
            .iter()
            .position(|o| o.name == name)
            .unwrap_or_else(|| panic!("{}: no object {name}", scene.name))
    }

    fn clip(scene: &Scene, view: View, object: usize) -> Vec<DVec4> {
        let o = &scene.objects[object];
        let mvp = scene.mvp_in(view, o, ASPECT);
        scene
            .vertex_positions(o)
            .into_iter()
            .map(|p| mvp * p.extend(1.0))
            .collect()
    }

    /// (min, max) of the object's NDC depth (its vertices: planar faces reach their extremes
    /// there, and depth is monotonic in view distance).
    fn depth_range(scene: &Scene, object: usize) -> (f64, f64) {
        clip(scene, View::Camera, object)
            .iter()
            .map(|c| c.z / c.w)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| {
                (lo.min(z), hi.max(z))
            })
    }

    fn depth_range_of(scene: &Scene, name: &str) -> (f64, f64) {
        depth_range(scene, find(scene, name))
    }

    /// NDC (x, y) bounding box: (min, max).
    fn screen_box(scene: &Scene, name: &str) -> ([f64; 2], [f64; 2]) {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for c in clip(scene, View::Camera, find(scene, name)) {
            for (axis, v) in [c.x / c.w, c.y / c.w].into_iter().enumerate() {
                lo[axis] = lo[axis].min(v);
                hi[axis] = hi[axis].max(v);
            }
        }
        (lo, hi)
    }

    /// Which objects a plan draws in passes of `target`.
    fn drawn_in(scene: &Scene, target: Target) -> Vec<usize> {
        let mut current = None;
        let mut drawn = Vec::new();
        for step in scene.plan.all_steps() {
            match step {
                Step::BeginPass(n) => current = Some(scene.plan.passes[*n].target),
                Step::Draw(n) | Step::DrawPushed(n) if current == Some(target) => {
                    drawn.push(*n);
                }
                _ => {}
            }
        }
        drawn
    }

    /// The accuracy scenes (issue #6): many objects, and checked by `crate::accuracy`.
    const ACCURACY: [&str; 7] = [
        "sloped-plane",
        "mars-patch",
        "tori",
        "plane-stack",
        "deep-range",
        "decal-bias",
        "far-objects",
    ];

    /// A margin well above the depth resolution of every format (D16: 1.5e-5).
    const MARGIN: f64 = 4e-4;

    #[test]
    fn the_catalog_matches_the_cli() {
        let ids = SceneId::value_variants();
        assert_eq!(CATALOG.len(), ids.len());
        for (entry, id) in CATALOG.iter().zip(ids) {
            assert_eq!(entry.id, *id);
            assert_eq!(id.to_possible_value().unwrap().get_name(), entry.name);
            assert_eq!((entry.build)().name, entry.name);
        }
    }

    #[test]
    fn every_plan_is_valid_and_draws_every_object() {
        for scene in all() {
            scene
                .plan
                .check(scene.objects.len(), scene.light.is_some())
                .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
            let mut drawn: Vec<usize> = drawn_in(&scene, Target::Main);
            drawn.extend(drawn_in(&scene, Target::Shadow));
            for n in 0..scene.objects.len() {
                assert!(
                    drawn.contains(&n),
                    "{}: {} is never drawn",
                    scene.name,
                    scene.objects[n].name
                );
            }
            assert!(
                scene.objects.len() <= 16 || ACCURACY.contains(&scene.name),
                "{}: too many objects",
                scene.name
            );
        }
    }

    #[test]
    fn every_vertex_is_within_the_depth_range_of_its_views() {
        for scene in all() {
            for (target, view) in [(Target::Main, View::Camera), (Target::Shadow, View::Light)] {
                // OpenGL's clip depth runs over [-1, 1]; the others over [0, 1].
                let negative_one_to_one =
                    view == View::Camera && scene.camera.projection.negative_one_to_one();
                let lowest = if negative_one_to_one { -1.0 } else { 0.0 };
                for n in drawn_in(&scene, target) {
                    for c in clip(&scene, view, n) {
                        let name = scene.objects[n].name;
                        assert!(c.w > 0.0, "{}: {name} behind the eye", scene.name);
                        let z = c.z / c.w;
                        assert!(
                            (lowest..=1.0).contains(&z),
                            "{}: {name} has depth {z} in {view:?}",
                            scene.name
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn needs_follow_from_the_plans() {
        let needs = |id: SceneId| id.build().plan.needs();
        assert!(needs(SceneId::Stencil).stencil);
        assert!(needs(SceneId::DepthBounds).depth_bounds);
        assert!(needs(SceneId::DynamicRendering).dynamic_rendering);
        assert!(needs(SceneId::CompareOpsDynamic).dynamic_compare_op);
        assert!(needs(SceneId::DepthBias).depth_bias_clamp);
        assert!(needs(SceneId::DepthBiasDynamic).depth_bias_clamp);
        assert!(needs(SceneId::ClearImage).clear_depth_image);
        assert!(needs(SceneId::PipelineLibrary).graphics_pipeline_library);
        assert!(needs(SceneId::ShadowMap).shadow_map);
        assert_eq!(needs(SceneId::Secondary).secondaries, 2);
        assert_eq!(needs(SceneId::Overlap), crate::plan::Needs::default());
        for id in [SceneId::MsaaResolve, SceneId::MsaaResolveDynamic] {
            let needs = needs(id);
            assert_eq!(
                needs.multisample,
                Some(Multisample {
                    samples: MSAA_SAMPLES,
                    depth_resolve: ResolveMode::SampleZero,
                })
            );
            assert_eq!(needs.dynamic_rendering, id == SceneId::MsaaResolveDynamic);
        }
        for scene in all() {
            let needs = scene.plan.needs();
            if scene.name != "stencil" {
                assert!(!needs.stencil, "{}", scene.name);
            }
            if scene.name != "depth-bounds" {
                assert!(!needs.depth_bounds, "{}", scene.name);
            }
            assert_eq!(
                needs.multisample.is_some(),
                scene.name.starts_with("msaa-"),
                "{}",
                scene.name
            );
        }
    }

    #[test]
    fn overlap_based_scenes_keep_the_overlap_geometry() {
        let overlap = overlap();
        for id in [
            SceneId::Secondary,
            SceneId::Subpasses,
            SceneId::MsaaResolve,
            SceneId::MsaaResolveDynamic,
        ] {
            let scene = id.build();
            let mut names: Vec<&str> = scene.objects.iter().map(|o| o.name).collect();
            let mut expected: Vec<&str> = overlap.objects.iter().map(|o| o.name).collect();
            names.sort_unstable();
            expected.sort_unstable();
            assert_eq!(names, expected, "{}", scene.name);
        }
        assert_eq!(secondary().objects, overlap.objects);
        // The multisampled scenes draw the overlap objects in the overlap order, with its
        // camera: only the sample count and the resolves differ.
        for scene in [msaa_resolve(), msaa_resolve_dynamic()] {
            assert_eq!(scene.objects, overlap.objects, "{}", scene.name);
            assert_eq!(scene.camera, overlap.camera, "{}", scene.name);
            assert_eq!(scene.plan.steps, overlap.plan.steps, "{}", scene.name);
        }
    }

    #[test]
    fn compare_ops_overlay_tiles_are_ground_tiles() {
        for scene in [compare_ops(), compare_ops_dynamic()] {
            let ground = &scene.objects[find(&scene, "ground")];
            let checker = &scene.objects[find(&scene, "checker overlay")];
            assert_eq!(ground.model, checker.model);
            assert_eq!(
                checker.mesh.positions.len() * 2,
                ground.mesh.positions.len()
            );
            // Every overlay tile is a ground tile: the same 4 vertices, the same triangles.
            for tile in checker.mesh.positions.chunks_exact(4) {
                assert!(
                    ground.mesh.positions.chunks_exact(4).any(|t| t == tile),
                    "{}: overlay tile {tile:?} is not a ground tile",
                    scene.name
                );
            }
            assert_eq!(
                &checker.mesh.indices[..6],
                &ground.mesh.indices[..6],
                "same triangulation"
            );
        }
    }

    #[test]
    fn compare_ops_extras_sit_where_their_op_shows_them() {
        let scene = compare_ops();
        // The ALWAYS cube is behind the middle cube, and inside its screen box.
        let (always, middle) = (
            depth_range_of(&scene, "always cube"),
            depth_range_of(&scene, "middle cube"),
        );
        assert!(always.0 > middle.0);
        let (alo, ahi) = screen_box(&scene, "always cube");
        let (mlo, mhi) = screen_box(&scene, "middle cube");
        assert!(alo[0] > mlo[0] && ahi[0] < mhi[0] && alo[1] > mlo[1] && ahi[1] < mhi[1]);
        // The GREATER cube is behind the near cube and overlaps it on screen.
        assert!(depth_range_of(&scene, "greater cube").0 > depth_range_of(&scene, "near cube").0);
        let (glo, ghi) = screen_box(&scene, "greater cube");
        let (nlo, nhi) = screen_box(&scene, "near cube");
        assert!(glo[0] < nhi[0] && nlo[0] < ghi[0] && glo[1] < nhi[1] && nlo[1] < ghi[1]);
        // The NEVER cube would be in plain view: inside the image, over the ground only.
        let (lo, hi) = screen_box(&scene, "never cube");
        assert!(lo[0] > -1.0 && hi[0] < 1.0 && lo[1] > -1.0 && hi[1] < 1.0);
        for other in ["near cube", "middle cube", "far cube", "slab"] {
            let (olo, ohi) = screen_box(&scene, other);
            assert!(ohi[0] < lo[0] || hi[0] < olo[0] || ohi[1] < lo[1] || hi[1] < olo[1]);
        }
    }

    #[test]
    fn clear_values_never_tie_with_a_surface() {
        let near = ["near floor", "near cube", "near cube 2"];
        let far = ["far floor", "far cube", "far cube 2"];
        for (scene, clear) in [(clear_render_pass(), 0.985), (clear_image(), 0.98)] {
            assert_eq!(scene.plan.main_clear_depth(), clear as f32);
            for name in near {
                assert!(depth_range_of(&scene, name).1 < 0.98 - MARGIN, "{name}");
            }
            for name in far {
                assert!(depth_range_of(&scene, name).0 > 0.985 + MARGIN, "{name}");
            }
            // The middle cube draws with 0.985, not with 0.98.
            let (lo, hi) = depth_range_of(&scene, "middle cube");
            assert!(lo > 0.98 + MARGIN && hi < 0.985 - MARGIN, "{lo} {hi}");
        }
    }

    #[test]
    fn clear_attachments_geometry_straddles_the_cleared_depth() {
        let scene = clear_attachments();
        let rect_ndc = CLEAR_RECT.map(|f| f64::from(f) * 2.0 - 1.0);
        let wall = depth_range_of(&scene, "wall");
        let bar = depth_range_of(&scene, "bar behind the wall");
        let block = depth_range_of(&scene, "far block");
        assert!(wall.1 < bar.0, "the bar is behind the wall");
        assert!(
            bar.1 < 0.98 - MARGIN,
            "the bar is nearer than the cleared depth"
        );
        assert!(block.0 > 0.98 + MARGIN, "the far block is beyond it");
        // The wall hides the bar on screen, the bar crosses the rectangle's sides, the block
        // overlaps the rectangle's top and sticks out of it.
        let (wlo, whi) = screen_box(&scene, "wall");
        let (blo, bhi) = screen_box(&scene, "bar behind the wall");
        assert!(wlo[0] < blo[0] && bhi[0] < whi[0] && wlo[1] < blo[1] && bhi[1] < whi[1]);
        assert!(blo[0] < rect_ndc[0] && bhi[0] > rect_ndc[2]);
        assert!(blo[1] > rect_ndc[1] && bhi[1] < rect_ndc[3]);
        let (klo, khi) = screen_box(&scene, "far block");
        assert!(klo[0] < rect_ndc[0] && khi[0] > rect_ndc[2]);
        assert!(klo[1] < rect_ndc[1] && khi[1] > rect_ndc[1]);
    }

    #[test]
    fn decals_are_coplanar_with_their_walls() {
        let scene = depth_bias();
        for (decal, wall) in [
            ("facing decal 1", "facing wall"),
            ("facing decal 2", "facing wall"),
            ("slanted decal 1", "slanted wall"),
            ("slanted decal under the rod", "slanted wall"),
        ] {
            let (d, w) = (
                &scene.objects[find(&scene, decal)],
                &scene.objects[find(&scene, wall)],
            );
            assert_eq!(d.model, w.model);
            assert!(d.mesh.positions.iter().all(|p| p[2] == 0.0));
            assert!(w.mesh.positions.iter().all(|p| p[2] == 0.0));
        }
        // The facing wall's depth is constant (its slope is zero): only the constant factor
        // separates its decals.
        let (lo, hi) = depth_range_of(&scene, "facing wall");
        assert!(hi - lo < 1e-6, "{lo} {hi}");
        // The rod is in front of the slanted wall by far more than the clamp.
        let rod = depth_range_of(&scene, "rod");
        let wall = depth_range_of(&scene, "slanted wall");
        assert!(rod.0 > wall.0 && rod.1 < wall.1);
    }

    /// Where the ray `origin + t * dir` (t > 0) meets the triangle, as t (Möller-Trumbore).
    fn ray_hits(origin: DVec3, dir: DVec3, [a, b, c]: [DVec3; 3]) -> Option<f64> {
        let (e1, e2) = (b - a, c - a);
        let p = dir.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-15 {
            return None;
        }
        let s = origin - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = dir.dot(q) / det;
        let t = e2.dot(q) / det;
        (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
    }

    /// The nearest world-space object of `scene` (but those in `skip`) that the ray
    /// `origin + t * dir` meets, with its t.
    fn nearest_hit(
        scene: &Scene,
        origin: DVec3,
        dir: DVec3,
        skip: &[usize],
    ) -> Option<(usize, f64)> {
        let mut nearest: Option<(usize, f64)> = None;
        for (n, object) in scene.objects.iter().enumerate() {
            if object.space != Space::World || skip.contains(&n) {
                continue;
            }
            for triangle in object.mesh.triangles() {
                let world = triangle.map(|p| object.model.transform_point3(p));
                if let Some(t) = ray_hits(origin, dir, world) {
                    if nearest.is_none_or(|(_, best)| t < best) {
                        nearest = Some((n, t));
                    }
                }
            }
        }
        nearest
    }

    #[test]
    fn pipeline_library_builds_every_pipeline_from_static_libraries() {
        let scene = pipeline_library();
        let plan = &scene.plan;
        assert!(plan.needs().graphics_pipeline_library);
        // A render pass: every library is given it and its subpass.
        assert!(plan.passes.iter().all(|p| p.kind == PassKind::RenderPass));
        for pipeline in &plan.pipelines {
            assert!(pipeline.libraries, "{}", pipeline.name);
            // All depth state static: in the libraries' create infos, nowhere else.
            assert!(matches!(pipeline.depth_test, DepthTest::Static(_)));
            assert!(matches!(pipeline.bias, Bias::Off | Bias::Static(_)));
            assert!(matches!(pipeline.viewport, Viewport::Static { .. }));
            assert_eq!(pipeline.bounds, Bounds::Off);
        }
        let spec = |name: &str| {
            plan.pipelines
                .iter()
                .find(|p| p.name == name)
                .unwrap_or_else(|| panic!("no pipeline {name}"))
        };
        assert_eq!(
            spec("standard").depth_test,
            DepthTest::Static(Compare::Less)
        );
        assert_eq!(spec("decal").bias, Bias::Static(DECAL_BIAS));
        assert!(!spec("decal").depth_write);
        assert_eq!(
            spec("sky").viewport,
            Viewport::Static {
                min_depth: 1.0,
                max_depth: 1.0
            }
        );
        assert_eq!(
            spec("sky").depth_test,
            DepthTest::Static(Compare::LessOrEqual)
        );
        // The overlap objects, unchanged.
        for object in overlap().objects {
            assert!(scene.objects.contains(&object), "{}", object.name);
        }
        // No other scene needs the extension.
        for other in all() {
            assert_eq!(
                other.plan.needs().graphics_pipeline_library,
                ["pipeline-library", "frag-depth-library"].contains(&other.name),
                "{}",
                other.name
            );
        }
    }

    #[test]
    fn pipeline_library_decals_lie_on_visible_faces_and_the_sky_behind_everything() {
        let scene = pipeline_library();
        let eye = scene.camera.eye;
        let decals = ["near cube decal", "middle cube decal"].map(|name| find(&scene, name));
        for (decal, cube, half) in [
            (decals[0], "near cube", NEAR_CUBE_HALF),
            (decals[1], "middle cube", MIDDLE_CUBE_HALF),
        ] {
            let cube = find(&scene, cube);
            let (d, c) = (&scene.objects[decal], &scene.objects[cube]);
            let name = d.name;
            // Exactly coplanar with the cube's +z face (the same model matrix, the face's own
            // f32 z), and inside its edges.
            assert_eq!(d.model, c.model, "{name}");
            let face_z = half as f32;
            assert!(
                c.mesh
                    .positions
                    .chunks_exact(4)
                    .any(|face| face.iter().all(|p| p[2] == face_z)),
                "{name}: the cube has no face at z = {face_z}"
            );
            for p in &d.mesh.positions {
                assert!(
                    p[2] == face_z && p[0].abs() < face_z && p[1].abs() < face_z,
                    "{name}"
                );
            }
            // The face turns toward the eye.
            let normal = d.model.transform_vector3(DVec3::Z);
            assert!(normal.dot(eye - d.world_center()) > 0.0, "{name}");
            // Over the whole decal (a 10 x 10 grid of points), the nearest surface the eye sees
            // is the decal's own face, at the decal: nothing else is in front of it, so the
            // bias alone decides whether it shows. And it is inside the image.
            let corners: Vec<DVec3> = d.mesh.positions_f64().collect();
            let view_projection = scene.view_projection(ASPECT);
            for i in 0..10 {
                for j in 0..10 {
                    let (u, v) = ((f64::from(i) + 0.5) / 10.0, (f64::from(j) + 0.5) / 10.0);
                    let local =
                        corners[0] + u * (corners[1] - corners[0]) + v * (corners[3] - corners[0]);
                    let point = d.model.transform_point3(local);
                    let (hit, t) = nearest_hit(&scene, eye, point - eye, &decals)
                        .unwrap_or_else(|| panic!("{name}: the eye sees nothing at {point}"));
                    assert_eq!(
                        hit, cube,
                        "{name}: {} in front at {point}",
                        scene.objects[hit].name
                    );
                    assert!((t - 1.0).abs() < 1e-9, "{name}: t = {t}");
                    let ndc = view_projection.project_point3(point);
                    assert!(ndc.x.abs() < 1.0 && ndc.y.abs() < 1.0, "{name} at {ndc}");
                }
            }
        }
        // The sky (viewport [1, 1], LESS_OR_EQUAL) passes only on the clear value: every
        // surface is nearer than 1 by far more than any format's resolution...
        let sky = find(&scene, "sky");
        for n in (0..scene.objects.len()).filter(|&n| n != sky) {
            let (_, far) = depth_range(&scene, n);
            assert!(far < 1.0 - MARGIN, "{}: {far}", scene.objects[n].name);
        }
        // ...and the top corners of the image see no surface (the sky shows there), the
        // bottom ones the ground.
        let inverse = scene.view_projection(ASPECT).inverse();
        let ground = find(&scene, "ground");
        for (x, y, sees) in [
            (-0.95, -0.95, None),
            (0.95, -0.95, None),
            (-0.95, 0.95, Some(ground)),
            (0.95, 0.95, Some(ground)),
        ] {
            let through = inverse.project_point3(DVec3::new(x, y, 0.5));
            let hit = nearest_hit(&scene, eye, through - eye, &[]).map(|(n, _)| n);
            assert_eq!(hit, sees, "at ({x}, {y})");
        }
    }

    #[test]
    fn viewport_split_ranges_separate_the_weapon_from_the_world() {
        let scene = viewport_split();
        let map = |[a, b]: [f32; 2], d: f64| f64::from(a) + (f64::from(b) - f64::from(a)) * d;
        let weapon = depth_range_of(&scene, "weapon");
        let post = depth_range_of(&scene, "lamp post");
        assert!(map(SPLIT_RANGES[0], weapon.1) + MARGIN < map(SPLIT_RANGES[1], 0.0));
        // The post is physically in front of the weapon's far end.
        assert!(post.0 < weapon.1);
        // The squeezed cube is physically in front of the far cube but lands behind it.
        let cube = depth_range_of(&scene, "squeezed cube");
        let far = depth_range_of(&scene, "far cube");
        assert!(cube.1 < far.1);
        assert!(map(SPLIT_RANGES[2], cube.0) > map(SPLIT_RANGES[1], far.1) + MARGIN);
        let (clo, chi) = screen_box(&scene, "squeezed cube");
        let (flo, fhi) = screen_box(&scene, "far cube");
        assert!(
            clo[0] < flo[0] && flo[0] < chi[0],
            "the cube crosses the far cube's edge"
        );
        assert!(clo[1] > -1.0 && chi[1] < flo[1] + 0.5 * (fhi[1] - flo[1]));
    }

    /// How one depth convention stores depth: the clear value, whether LESS is swapped for
    /// GREATER, the depth rasterized for a surface at standard depth D (what flat programs
    /// store and `gl_FragCoord.z` holds), and the maps applied to `gl_FragCoord.z` loads and
    /// `FragDepth` stores of [`Program::FragDepth`] (a layer's rewrite; identity natively).
    struct Convention {
        name: &'static str,
        clear: f64,
        greater: bool,
        rasterized: &'static dyn Fn(f64) -> f64,
        load: &'static dyn Fn(f64) -> f64,
        store: &'static dyn Fn(f64) -> f64,
    }

    /// The stored depth of `frag-depth`'s object `n` (its cards have one depth each) under
    /// `convention`, drawn with `program`.
    fn card_depth(scene: &Scene, n: usize, program: Program, convention: &Convention) -> f64 {
        let (lo, hi) = depth_range(scene, n);
        assert!(
            hi - lo < 1e-9,
            "{}: not facing the eye",
            scene.objects[n].name
        );
        let rasterized = (convention.rasterized)(lo);
        match program {
            Program::FragDepth => {
                (convention.store)(program.frag_depth((convention.load)(rasterized)))
            }
            _ => rasterized,
        }
    }

    /// Replays `frag-depth`'s draws at the NDC point `at` (the cards are rectangles facing the
    /// eye: their screen boxes are what they cover) with `convention`: the object that shows
    /// there, if any. Every depth test is asserted to be decided by more than [`MARGIN`].
    fn frag_depth_winner(scene: &Scene, at: [f64; 2], convention: &Convention) -> Option<usize> {
        let mut stored = convention.clear;
        let mut shows = None;
        let mut program = Program::Flat;
        for step in &scene.plan.steps {
            match step {
                Step::Bind(p) => {
                    let pipeline = &scene.plan.pipelines[*p];
                    assert_eq!(pipeline.depth_test, DepthTest::Static(Compare::Less));
                    assert!(pipeline.depth_write);
                    program = pipeline.program;
                }
                Step::Draw(n) => {
                    let (lo, hi) = screen_box(scene, scene.objects[*n].name);
                    if !(lo[0] < at[0] && at[0] < hi[0] && lo[1] < at[1] && at[1] < hi[1]) {
                        continue;
                    }
                    let depth = card_depth(scene, *n, program, convention);
                    assert!(
                        (depth - stored).abs() > MARGIN,
                        "{}: {} ties at {at:?}: {depth} against {stored}",
                        convention.name,
                        scene.objects[*n].name
                    );
                    let op = if convention.greater {
                        Compare::Greater
                    } else {
                        Compare::Less
                    };
                    if op.passes(depth, stored) {
                        stored = depth;
                        shows = Some(*n);
                    }
                }
                _ => {}
            }
        }
        shows
    }

    #[test]
    fn frag_depth_library_is_frag_depth_built_from_libraries() {
        let (plain, library) = (frag_depth(), frag_depth_library());
        assert!(library.plan.needs().graphics_pipeline_library);
        assert_eq!(library.objects, plain.objects);
        assert_eq!(library.plan.steps, plain.plan.steps);
        assert_eq!(library.plan.passes, plain.plan.passes);
        assert!(library
            .plan
            .passes
            .iter()
            .all(|p| p.kind == PassKind::RenderPass));
        for (with, without) in library.plan.pipelines.iter().zip(&plain.plan.pipelines) {
            assert!(with.libraries, "{}", with.name);
            assert_eq!(
                &PipelineSpec {
                    libraries: false,
                    ..with.clone()
                },
                without
            );
        }
    }

    #[test]
    fn frag_depth_pushes_the_near_card_between_the_others() {
        let scene = frag_depth();
        let [wall, pushed, middle] =
            ["far wall", "pushed card", "middle card"].map(|name| find(&scene, name));
        assert_eq!(scene.plan.main_clear_depth(), 1.0);
        // Standard depths: the pushed card is geometrically the nearest...
        let depth = |n| depth_range(&scene, n).0;
        assert!(depth(pushed) + MARGIN < depth(middle) && depth(middle) + MARGIN < depth(wall));
        // ...and its FragDepth puts it between the middle card and the wall.
        let pushed_back = Program::FragDepth.frag_depth(depth(pushed));
        assert_eq!(pushed_back, 0.5 + 0.5 * depth(pushed));
        assert!(depth(middle) + MARGIN < pushed_back && pushed_back + MARGIN < depth(wall));
        assert!(
            pushed_back < 1.0 - MARGIN,
            "in front of the clear with margin"
        );

        // Which object shows where: (point in NDC, natively, under a layer that forgets to map
        // FragDepth stores or gl_FragCoord.z loads). Only the overlap of the pushed and the
        // middle card changes.
        let regions = [
            ([0.0, -0.4], Some(pushed), Some(pushed)), // the pushed card alone (upper band)
            ([0.0, 0.05], Some(pushed), Some(pushed)), // the pushed card alone (between)
            ([-0.3, 0.05], Some(pushed), Some(pushed)), // the pushed card over the wall
            ([0.3, 0.05], Some(middle), Some(pushed)), // the middle card over the pushed card
            ([-0.6, 0.5], Some(wall), Some(wall)),
            ([0.6, 0.5], Some(middle), Some(middle)),
            ([0.0, 0.5], None, None),
            ([-0.9, -0.9], None, None),
        ];
        let flip = &|d: f64| 1.0 - d;
        let same = &|d: f64| d;
        // Infinite reversed-Z stores n/w = 1 - (1 - n/f) D; a rewrite baking the complementary
        // map is off by up to n/f = 1e-3 (the scenes' margins must absorb it).
        assert_eq!((scene.camera.near, scene.camera.far), (0.1, 100.0));
        let infinite = &|d: f64| 1.0 - (1.0 - 0.1 / 100.0) * d;
        let native = Convention {
            name: "native",
            clear: 1.0,
            greater: false,
            rasterized: same,
            load: same,
            store: same,
        };
        let reversed = |name, rasterized, load, store| Convention {
            name,
            clear: 0.0,
            greater: true,
            rasterized,
            load,
            store,
        };
        let right = [
            reversed("reversed", flip, flip, flip),
            reversed("infinite", infinite, flip, flip),
        ];
        let wrong = [
            reversed("stores unflipped", flip, flip, same),
            reversed("loads unflipped", flip, same, flip),
            reversed("shader untouched", flip, same, same),
            reversed("infinite, stores unflipped", infinite, flip, same),
            reversed("infinite, loads unflipped", infinite, same, flip),
        ];
        for (at, expected, when_wrong) in regions {
            assert_eq!(
                frag_depth_winner(&scene, at, &native),
                expected,
                "native at {at:?}"
            );
            for convention in &right {
                assert_eq!(
                    frag_depth_winner(&scene, at, convention),
                    expected,
                    "{} at {at:?}",
                    convention.name
                );
            }
            for convention in &wrong {
                assert_eq!(
                    frag_depth_winner(&scene, at, convention),
                    when_wrong,
                    "{} at {at:?}",
                    convention.name
                );
            }
        }

        // The cards overlap as the regions say, and stay inside the image.
        for name in ["far wall", "pushed card", "middle card"] {
            let (lo, hi) = screen_box(&scene, name);
            assert!(
                lo[0] > -1.0 && lo[1] > -1.0 && hi[0] < 1.0 && hi[1] < 1.0,
                "{name}"
            );
        }
        // No ground truth: the nearest surface does not win.
        let refused = crate::ground_truth::applies(&scene).unwrap_err();
        assert!(refused.contains("FragDepth"), "{refused}");
    }

    /// The scenes with a ground truth: exactly those where the nearest surface decides.
    #[test]
    fn ground_truth_applies_where_the_nearest_surface_wins() {
        let with: Vec<&str> = all()
            .iter()
            .filter(|s| crate::ground_truth::applies(s).is_ok())
            .map(|s| s.name)
            .collect();
        assert_eq!(
            with,
            [
                "overlap",
                "secondary",
                "dynamic-rendering",
                "shadow-map",
                "shadow-map-secondaries",
                "projection-only",
                "view-projection",
                "model-view-projection-pair",
                "row-major",
                "opengl-depth",
                "already-reversed",
                "push-partial",
                "threads",
                "lit-mvp",
                "sloped-plane",
                "mars-patch",
                "tori",
                "plane-stack",
                "deep-range",
                "far-objects",
            ]
        );
        for scene in all() {
            let Ok(drawn) = crate::ground_truth::applies(&scene) else {
                continue;
            };
            let (truth, report) = crate::ground_truth::compute(&scene, 96, 64).unwrap();
            assert_eq!(drawn.len(), report.objects.len());
            assert!(
                truth.interior > 96 * 64 / 2 || ACCURACY.contains(&scene.name),
                "{}: {} interior pixels",
                scene.name,
                truth.interior
            );
            // Every object drawn shows somewhere, except what the scene hides on purpose.
            for object in &report.objects {
                let shows = truth.ids.contains(&object.id);
                assert!(
                    shows || scene.name == "shadow-map" || scene.name == "plane-stack",
                    "{}: {}",
                    scene.name,
                    object.name
                );
            }
        }
    }

    /// Replays a plan's push constants byte by byte (per command buffer, as Vulkan keeps them):
    /// at every draw without a push, the bytes there are exactly the drawn object's own.
    #[test]
    fn partial_pushes_leave_every_object_its_own_constants() {
        let mut replayed = 0;
        for scene in all() {
            let aspect = 1.5;
            let lists: Vec<Vec<&Step>> = {
                let mut lists = vec![Vec::new()];
                for step in &scene.plan.steps {
                    match step {
                        Step::ExecuteSecondaries(inner, _) => {
                            lists.extend(inner.iter().map(|l| l.iter().collect()));
                        }
                        other => lists[0].push(other),
                    }
                }
                lists
            };
            for list in lists {
                let mut bytes = [0u8; 128];
                let mut program = Program::Flat;
                for step in list {
                    match step {
                        Step::Bind(n) => program = scene.plan.pipelines[*n].program,
                        Step::Draw(n) => {
                            let own = scene.push_constants(program, &scene.objects[*n], aspect);
                            bytes[..own.len()].copy_from_slice(&own);
                        }
                        Step::Push {
                            object,
                            offset,
                            size,
                        } => {
                            let own =
                                scene.push_constants(program, &scene.objects[*object], aspect);
                            let range = *offset as usize..(offset + size) as usize;
                            bytes[range.clone()].copy_from_slice(&own[range]);
                        }
                        Step::DrawPushed(n) => {
                            let own = scene.push_constants(program, &scene.objects[*n], aspect);
                            assert_eq!(
                                &bytes[..own.len()],
                                &own[..],
                                "{}: {} is drawn with someone else's constants",
                                scene.name,
                                scene.objects[*n].name
                            );
                            replayed += 1;
                        }
                        _ => {}
                    }
                }
            }
        }
        assert_eq!(
            replayed, 4,
            "push-partial has four draws without a full push"
        );
    }

    #[test]
    fn push_partial_updates_the_ranges_it_claims() {
        let scene = push_partial();
        let pushes: Vec<(&str, u32, u32)> = scene
            .plan
            .steps
            .iter()
            .filter_map(|step| match step {
                Step::Push {
                    object,
                    offset,
                    size,
                } => Some((scene.objects[*object].name, *offset, *size)),
                _ => None,
            })
            .collect();
        assert_eq!(
            pushes,
            [
                ("lid", 64, 16),
                ("moved cube", 48, 16),
                ("green cube", 0, 32),
                ("green cube", 32, 48),
                ("pillar", 0, 48),
                ("pillar", 64, 16),
            ]
        );
        // What the partial pushes skip really is shared: the lid's matrix is the red cube's,
        // the moved cube differs from the lid only in the translation column (and keeps its
        // color), the pillar from the green cube only in the first three columns and color.
        let bytes =
            |name| scene.push_constants(Program::Flat, &scene.objects[find(&scene, name)], 1.0);
        let (red, lid, moved) = (bytes("red cube"), bytes("lid"), bytes("moved cube"));
        assert_eq!(red[..64], lid[..64]);
        assert_ne!(red[64..], lid[64..]);
        assert_eq!(lid[..48], moved[..48]);
        assert_eq!(lid[64..], moved[64..]);
        assert_ne!(lid[48..64], moved[48..64]);
        let (green, pillar) = (bytes("green cube"), bytes("pillar"));
        assert_eq!(green[48..64], pillar[48..64]);
        assert_ne!(green[..48], pillar[..48]);
        assert_ne!(green[64..], pillar[64..]);
    }

    #[test]
    fn programs_lay_out_the_same_transform_their_own_way() {
        let scene = model_view_projection_pair();
        let object = &scene.objects[find(&scene, "middle cube")];
        let mvp = scene.mvp(object, ASPECT);
        let floats = |bytes: Vec<u8>| -> Vec<f32> {
            bytes
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                .collect()
        };
        // Row-major: the transpose of the column-major bytes, then the color.
        let columns = floats(scene.push_constants(Program::Flat, object, ASPECT));
        for program in [Program::RowMajor, Program::RowVector] {
            let rows = floats(scene.push_constants(program, object, ASPECT));
            for r in 0..4 {
                for c in 0..4 {
                    assert_eq!(rows[r * 4 + c], columns[c * 4 + r]);
                }
            }
            assert_eq!(rows[16..], columns[16..]);
        }
        // The pair: M at 0, P * V at 64, no color; P * V is what a layer sees as projection,
        // and the two stages compose to the MVP.
        let pair = floats(scene.push_constants(Program::MvpPair, object, ASPECT));
        assert_eq!(pair.len(), 32);
        assert_eq!(pair[..16], object.model.as_mat4().to_cols_array());
        let view_projection = scene.view_projection(ASPECT).as_mat4().to_cols_array();
        assert_eq!(pair[16..], view_projection);
        assert_eq!(
            scene.pushed_projection(Program::MvpPair, object, ASPECT),
            view_projection
        );
        let stages = scene.matrix_stages(Program::MvpPair, View::Camera, object, ASPECT);
        assert!((stages[0] * stages[1]).abs_diff_eq(mvp, 1e-12));
    }

    #[test]
    fn baked_vertices_land_where_the_world_path_puts_them() {
        for scene in [projection_only(), view_projection()] {
            let space = scene.objects[0].space;
            assert!(matches!(space, Space::ViewBaked | Space::WorldBaked));
            let pushed = scene.mvp_in(View::Camera, &scene.objects[0], ASPECT);
            let expected = match space {
                Space::ViewBaked => scene.camera.projection(ASPECT),
                _ => scene.view_projection(ASPECT),
            };
            assert_eq!(pushed, expected, "{}", scene.name);
            for object in &scene.objects {
                let world = Object {
                    space: Space::World,
                    ..object.clone()
                };
                let by_world = scene.mvp_in(View::Camera, &world, ASPECT);
                let by_bake = scene.mvp_in(View::Camera, object, ASPECT);
                for (p, q) in object
                    .mesh
                    .positions_f64()
                    .zip(scene.vertex_positions(object))
                {
                    let (a, b) = (by_world * p.extend(1.0), by_bake * q.extend(1.0));
                    // The bake rounds once to f32: relative 1e-7 of the coordinates.
                    assert!((a - b).abs().max_element() < 1e-6 * a.abs().max_element());
                }
            }
        }
    }

    #[test]
    fn view_projection_reaches_far_inside_its_planes() {
        let scene = view_projection();
        let camera = &scene.camera;
        let farthest = (0..scene.objects.len())
            .flat_map(|n| clip(&scene, View::Camera, n))
            .map(|c| c.w)
            .fold(0.0, f64::max);
        assert!(farthest > 800.0 && farthest < camera.far, "{farthest}");
    }

    #[test]
    fn threads_record_every_object_once_each_list_binding_its_own_state() {
        let scene = threads();
        let [Step::BeginPass(0), Step::ExecuteSecondaries(lists, Recording::ThreadPerSecondary), Step::EndPass] =
            &scene.plan.steps[..]
        else {
            panic!("{:?}", scene.plan.steps);
        };
        assert_eq!(lists.len(), THREADS);
        let mut drawn = Vec::new();
        for list in lists {
            assert!(matches!(list[0], Step::Bind(_)));
            assert!(matches!(list[1], Step::SetViewport { .. }));
            drawn.extend(list.iter().filter_map(|s| match s {
                Step::Draw(n) => Some(*n),
                _ => None,
            }));
        }
        drawn.sort_unstable();
        assert_eq!(drawn, (0..scene.objects.len()).collect::<Vec<_>>());
        assert_eq!(
            scene.plan.needs().secondaries,
            0,
            "no secondary from the main pool"
        );
        let mut names: Vec<&str> = scene.objects.iter().map(|o| o.name).collect();
        let mut expected: Vec<&str> = overlap().objects.iter().map(|o| o.name).collect();
        names.sort_unstable();
        expected.sort_unstable();
        assert_eq!(names, expected);
    }

    #[test]
    fn the_depth_conventions_follow_the_cameras() {
        let gl = opengl_depth();
        assert!(gl.plan.pipelines.iter().all(|p| p.negative_one_to_one));
        assert!(gl.plan.needs().depth_clip_control);
        let reversed = already_reversed();
        assert_eq!(reversed.plan.main_clear_depth(), 0.0);
        assert_eq!(
            reversed.plan.pipelines[0].depth_test,
            DepthTest::Static(Compare::Greater)
        );
        // Depth decreases with distance: the near cube's nearest vertex is above the far
        // cube's farthest.
        let near = depth_range_of(&reversed, "near cube");
        let far = depth_range_of(&reversed, "far cube");
        assert!(near.0 > far.1);
        for scene in all() {
            if scene.name != "opengl-depth" {
                assert!(!scene.plan.needs().depth_clip_control, "{}", scene.name);
            }
        }
    }

    #[test]
    fn shadow_casters_fit_in_the_light_box() {
        let scene = shadow_map();
        for (n, object) in scene.objects.iter().enumerate() {
            if object.name == "ground" {
                continue;
            }
            for c in clip(&scene, View::Light, n) {
                assert!(c.x.abs() < 1.0 && c.y.abs() < 1.0, "{} at {c}", object.name);
            }
        }
        assert_eq!(scene.light_mvps().len(), scene.objects.len());
    }

    /// The f64 model of `lit_mvp.frag` for the clip transform `mvp` at the model-space point
    /// `p` of a flat face spanned by the model-space tangents `tangents`, with base color
    /// `color`: linear RGB before the UNORM store. The shader's normal is
    /// `cross(dFdx(v), dFdy(v))` of the view vector `v = -(mvp * p).xyz`: the screen
    /// derivatives of `v` along a face are the rows 0..2 of `mvp` applied to tangents of the
    /// face, so its direction is that of `cross(A t1, A t2)` (A: the linear part of those
    /// rows), turned toward `v` as the shader turns it.
    fn lit_shade(mvp: &DMat4, p: DVec3, tangents: [DVec3; 2], color: [f32; 4]) -> DVec3 {
        let linear = |t: DVec3| (*mvp * t.extend(0.0)).truncate();
        let v = (-(*mvp * p.extend(1.0)).truncate()).normalize();
        let mut n = linear(tangents[0]).cross(linear(tangents[1])).normalize();
        if n.dot(v) < 0.0 {
            n = -n;
        }
        let l = DVec3::new(-0.35, -0.55, -0.75).normalize();
        let diffuse = n.dot(l).max(0.0);
        // reflect(-l, n) = -l - 2 dot(n, -l) n.
        let reflected = -l + 2.0 * n.dot(l) * n;
        let specular = reflected.dot(v).max(0.0).powi(32);
        let base = DVec3::new(
            f64::from(color[0]),
            f64::from(color[1]),
            f64::from(color[2]),
        );
        base * (0.3 + 0.7 * diffuse) + DVec3::splat(0.5 * specular)
    }

    /// A shaded color as the R8G8B8A8_UNORM attachment stores it.
    fn unorm8(color: DVec3) -> [u8; 3] {
        color
            .to_array()
            .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
    }

    /// `mvp` with its depth row replaced by `k' r3 + b' e3` (r3: its w row): what a layer
    /// rewriting the pushed matrix to the reversed mapping (k', b') pushes.
    fn with_depth_row(mvp: &DMat4, k: f64, b: f64) -> DMat4 {
        let mut m = *mvp;
        let w_row = mvp.row(3);
        for col in 0..4 {
            let e3 = if col == 3 { b } else { 0.0 };
            m.col_mut(col)[2] = k * w_row[col] + e3;
        }
        m
    }

    /// For every interior pixel of `lit-mvp`'s ground truth (96 x 64): the box, the model-space
    /// point it shows and the tangents of that point's face.
    fn lit_pixels(scene: &Scene) -> Vec<(usize, DVec3, [DVec3; 2])> {
        let (width, height) = (96u32, 64u32);
        let aspect = f64::from(width) / f64::from(height);
        let (truth, _) = crate::ground_truth::compute(scene, width, height).unwrap();
        let camera = &scene.camera;
        let t = (camera.fov_y / 2.0).tan();
        let view_to_world = camera.view().inverse();
        let mut pixels = Vec::new();
        for (at, &w) in truth.w.iter().enumerate() {
            if !w.is_finite() {
                continue;
            }
            let (px, py) = (at % width as usize, at / width as usize);
            let x = (px as f64 + 0.5) / f64::from(width) * 2.0 - 1.0;
            let y = (py as f64 + 0.5) / f64::from(height) * 2.0 - 1.0;
            let view = DVec3::new(x * t * aspect * w, -y * t * w, -w);
            let n = usize::from(truth.ids[at]);
            let object = &scene.objects[n];
            let p = object
                .model
                .inverse()
                .transform_point3(view_to_world.transform_point3(view));
            // The face: the axis along which the point is farthest out, relative to the box.
            let half = object
                .mesh
                .positions_f64()
                .fold(DVec3::ZERO, |h, q| h.max(q.abs()));
            let axis = (p / half).abs().max_position();
            let tangents = [DVec3::AXES[(axis + 1) % 3], DVec3::AXES[(axis + 2) % 3]];
            pixels.push((n, p, tangents));
        }
        pixels
    }

    #[test]
    fn lit_mvp_pushes_scene_vert_constants_and_culls_back_faces() {
        let scene = lit_mvp();
        let [pipeline] = &scene.plan.pipelines[..] else {
            panic!("{:?}", scene.plan.pipelines);
        };
        assert_eq!(pipeline.program, Program::LitMvp);
        assert!(pipeline.cull_back_faces);
        assert_eq!(Program::LitMvp.push_constant_size(), 80);
        // The layout of scene.vert: the MVP column-major, then the color.
        for object in &scene.objects {
            assert_eq!(
                scene.push_constants(Program::LitMvp, object, ASPECT),
                scene.push_constants(Program::Flat, object, ASPECT),
                "{}",
                object.name
            );
        }
        // Every box is a closed cuboid wound outward: culling keeps the faces the nearest
        // surface is on, so the ground truth is the unculled one.
        let (culled, _) = crate::ground_truth::compute(&scene, 96, 64).unwrap();
        let mut unculled = scene.clone();
        unculled.plan.pipelines[0].cull_back_faces = false;
        let (all, _) = crate::ground_truth::compute(&unculled, 96, 64).unwrap();
        assert_eq!(culled.ids, all.ids);
        let bits = |truth: &crate::ground_truth::GroundTruth| -> Vec<u64> {
            truth.w.iter().map(|w| w.to_bits()).collect()
        };
        assert_eq!(bits(&culled), bits(&all));
    }

    #[test]
    fn lit_mvp_boxes_lie_in_depth_ranges_of_their_own() {
        let scene = lit_mvp();
        let mut ranges: Vec<(f64, f64, &str)> = (0..scene.objects.len())
            .map(|n| {
                let (lo, hi) = clip(&scene, View::Camera, n)
                    .iter()
                    .fold((f64::INFINITY, 0.0f64), |(lo, hi), c| {
                        (lo.min(c.w), hi.max(c.w))
                    });
                (lo, hi, scene.objects[n].name)
            })
            .collect();
        ranges.sort_by(|a, b| a.0.total_cmp(&b.0));
        for pair in ranges.windows(2) {
            let (near, far) = (pair[0], pair[1]);
            assert!(
                far.0 > near.1 * 1.04,
                "{} reaches {:.3}, {} starts at {:.3}",
                near.2,
                near.1,
                far.2,
                far.0
            );
        }
        // The nearest and farthest surfaces, well inside the camera's planes.
        assert!(ranges[0].0 > 30.0 * scene.camera.near, "{ranges:?}");
        assert!(
            ranges.last().unwrap().1 < 0.5 * scene.camera.far,
            "{ranges:?}"
        );
        // Nearest first, so the draw order never decides a pixel.
        let depths: Vec<f64> = scene.objects.iter().map(|o| scene.view_depth(o)).collect();
        assert!(depths.windows(2).all(|w| w[0] < w[1]), "{depths:?}");
    }

    /// The shading sees the pushed matrix's depth row: with the depth row replaced by the
    /// complementary or the infinite reversed one (what a layer rewriting the pushed matrix
    /// hands the shader), most interior pixels get another color, while the float32 rounding
    /// of the matrix the application pushes changes next to none. So comparing the render
    /// through the layer with the native one catches a layer that rewrites the matrix.
    #[test]
    fn lit_mvp_colors_change_with_the_depth_row() {
        let scene = lit_mvp();
        let aspect = 96.0 / 64.0;
        let (n, f) = (scene.camera.near, scene.camera.far);
        let pixels = lit_pixels(&scene);
        assert!(
            pixels.len() > 96 * 64 / 2,
            "{} interior pixels",
            pixels.len()
        );
        let differing = |change: &dyn Fn(&DMat4) -> DMat4| {
            pixels
                .iter()
                .filter(|&&(object, p, tangents)| {
                    let o = &scene.objects[object];
                    let mvp = scene.mvp(o, aspect);
                    let native = unorm8(lit_shade(&mvp, p, tangents, o.color));
                    let changed = unorm8(lit_shade(&change(&mvp), p, tangents, o.color));
                    native.iter().zip(changed).any(|(a, b)| a.abs_diff(b) > 1)
                })
                .count() as f64
                / pixels.len() as f64
        };
        let complementary = differing(&|m| with_depth_row(m, -n / (f - n), f * n / (f - n)));
        let infinite = differing(&|m| with_depth_row(m, 0.0, n));
        let rounded = differing(&|m| m.as_mat4().as_dmat4());
        eprintln!(
            "lit-mvp pixels whose color changes by more than 1/255: complementary depth row              {complementary:.3}, infinite {infinite:.3}, float32 rounding {rounded:.4}"
        );
        assert!(
            complementary > 0.5 && infinite > 0.5,
            "{complementary} {infinite}"
        );
        assert!(rounded < 0.01, "{rounded}");
        // The shading is not flat: every box shows several colors, the wall a highlight.
        for (object, o) in scene.objects.iter().enumerate() {
            let mvp = scene.mvp(o, aspect);
            let mut colors: Vec<[u8; 3]> = pixels
                .iter()
                .filter(|p| p.0 == object)
                .map(|&(_, p, tangents)| unorm8(lit_shade(&mvp, p, tangents, o.color)))
                .collect();
            colors.sort_unstable();
            colors.dedup();
            assert!(colors.len() >= 3, "{}: {colors:?}", o.name);
        }
    }

    /// The scenes the buffer deliveries are meant for (issue #16).
    const DELIVERY_SCENES: [&str; 6] = [
        "overlap",
        "sloped-plane",
        "mars-patch",
        "plane-stack",
        "deep-range",
        "far-objects",
    ];

    fn floats(bytes: &[u8]) -> Vec<f32> {
        bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    #[test]
    fn buffer_deliveries_take_the_flat_scenes_and_refuse_special_programs() {
        use crate::plan::Delivery;
        for scene in all() {
            let same = scene.with_delivery(Delivery::Push).unwrap();
            assert_eq!(same, scene, "push changes nothing");
            for delivery in [Delivery::Ubo, Delivery::UboDynamic, Delivery::Ssbo] {
                let program = delivery.program().unwrap();
                match scene.with_delivery(delivery) {
                    Ok(taken) => {
                        taken
                            .plan
                            .check(taken.objects.len(), taken.light.is_some())
                            .unwrap_or_else(|e| panic!("{} {delivery:?}: {e}", scene.name));
                        assert!(
                            taken.plan.pipelines.iter().all(|p| p.program == program),
                            "{} {delivery:?}",
                            scene.name
                        );
                        assert_eq!(taken.objects, scene.objects);
                        assert_eq!(taken.plan.needs(), scene.plan.needs());
                        // The ground truth comes from the scene, not the delivery.
                        // (w compared bit for bit: NaN where a pixel is not interior.)
                        let bits = |t: &crate::ground_truth::GroundTruth| {
                            (
                                t.ids.clone(),
                                t.w.iter().map(|w| w.to_bits()).collect::<Vec<_>>(),
                            )
                        };
                        if let Ok(truth) = crate::ground_truth::compute_ids(&scene, 48, 36) {
                            let taken_truth =
                                crate::ground_truth::compute_ids(&taken, 48, 36).unwrap();
                            assert!(
                                bits(&taken_truth) == bits(&truth),
                                "{} {delivery:?}: another ground truth",
                                scene.name
                            );
                        }
                    }
                    Err(why) => {
                        assert!(
                            !DELIVERY_SCENES.contains(&scene.name),
                            "{} refuses {delivery:?}: {why}",
                            scene.name
                        );
                        assert!(
                            why.contains(scene.name) && why.contains(delivery.name()),
                            "{why}"
                        );
                    }
                }
            }
        }
        // Special programs, shadow passes and partial pushes are refused, saying why.
        for (scene, why) in [
            (SceneId::ModelViewProjectionPair, "MvpPair program"),
            (SceneId::LitMvp, "LitMvp program"),
            (SceneId::RowMajor, "RowMajor program"),
            (SceneId::FragDepth, "FragDepth program"),
            (SceneId::ShadowMap, "program"),
            (SceneId::PushPartial, "updates push constants"),
        ] {
            let error = scene.build().with_delivery(Delivery::Ubo).unwrap_err();
            assert!(error.contains(why), "{error}");
        }
    }

    #[test]
    fn buffer_blocks_hold_the_delivered_matrices_rounded_once() {
        use crate::plan::{Delivery, Program};
        let aspect = 4.0 / 3.0;
        for name in DELIVERY_SCENES {
            let scene = SceneId::from_str(name, false).unwrap().build();
            for object in &scene.objects {
                let push = floats(&scene.push_constants(Program::Flat, object, aspect));
                let mvp = scene.mvp_in(View::Camera, object, aspect);
                // ssbo: exactly the push constants (the same float32 P * V * M and color).
                let ssbo = floats(&scene.object_block(Program::Ssbo, object, aspect));
                assert_eq!(ssbo, push, "{name}");
                // ubo: P, V and M apart, each rounded from f64; their f64 product is the MVP.
                let ubo = floats(&scene.object_block(Program::Ubo, object, aspect));
                assert_eq!(ubo.len(), 52);
                let [p, v, m] = scene.separate_matrices(object, aspect);
                for (k, matrix) in [p, v, m].iter().enumerate() {
                    assert_eq!(
                        ubo[16 * k..16 * (k + 1)],
                        matrix.as_mat4().to_cols_array(),
                        "{name}"
                    );
                }
                assert_eq!(ubo[48..], object.color);
                let largest = mvp.abs().to_cols_array().into_iter().fold(0.0, f64::max);
                assert!((p * v * m).abs_diff_eq(mvp, 1e-12 * largest), "{name}");
                assert_eq!(
                    scene.pushed_projection(Program::Ubo, object, aspect),
                    p.as_mat4().to_cols_array()
                );
                // ubo-dynamic: the shared frame's P * V and the object's model.
                let model = floats(&scene.object_block(Program::UboDynamic, object, aspect));
                let frame = floats(&scene.frame_block(aspect));
                let (inner, outer) = scene.model_split(View::Camera, object, aspect);
                assert_eq!(frame, outer.as_mat4().to_cols_array(), "{name}");
                assert_eq!(model[..16], inner.as_mat4().to_cols_array());
                assert_eq!(model[16..], object.color);
                assert_eq!(
                    scene.pushed_projection(Program::UboDynamic, object, aspect),
                    outer.as_mat4().to_cols_array()
                );
                assert_eq!(
                    scene.matrix_stages(Program::Ubo, View::Camera, object, aspect),
                    vec![p, v, m]
                );
            }
            // Push constants are not used by the buffer deliveries.
            let taken = scene.with_delivery(Delivery::Ubo).unwrap();
            assert_eq!(taken.plan.pipelines[0].program.push_constant_size(), 0);
            assert!(scene
                .push_constants(Program::Ubo, &scene.objects[0], aspect)
                .is_empty());
        }
    }
}
