//! The scenes of depth state: compare ops, clears, bias, bounds, viewport depth ranges and
//! stencil (each exercises one piece of state a reversed attachment must follow).

use super::*;

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

/// `compare-ops-unsorted`: the `compare-ops` image with its depth pre-pass drawn farthest first
/// (engines that pre-pass by material or occluder list, not front to back), so that in a
/// frame's first recording the camera's later matrices are better conditioned than its first.
///
/// Layer item: every draw of one camera in a recording stores depth on one line. Before session
/// 39 the camera's range improved mid-recording: the pre-pass stored each far object's depth on
/// a worse line than the EQUAL pass after it, and 46% of the image (every object drawn before
/// the nearest in the pre-pass) lost its color in the first frame, and in every frame of a
/// projection that changes each frame (an animated field of view).
pub fn compare_ops_unsorted() -> Scene {
    compare_ops_scene_drawn("compare-ops-unsorted", false, true)
}

fn compare_ops_scene(name: &'static str, dynamic: bool) -> Scene {
    compare_ops_scene_drawn(name, dynamic, false)
}

/// The compare-ops scenes; `far_first`: the pre-pass draws its objects farthest first.
fn compare_ops_scene_drawn(name: &'static str, dynamic: bool, far_first: bool) -> Scene {
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
    if far_first {
        let far_first: Vec<usize> = opaque.iter().rev().copied().collect();
        b.draw(&far_first);
    } else {
        b.draw(&opaque);
    }

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

/// The depths of `depth-range-unrestricted`: the clear value, the world's viewport range, the
/// squeezed cube's, and the range of the clamped cube beyond the far plane.
pub const UNRESTRICTED_CLEAR: f32 = 1.5;
pub const UNRESTRICTED_WORLD: [f32; 2] = [-20.0, 1.5];
pub const UNRESTRICTED_SQUEEZED: [f32; 2] = [1.2, 1.4];
pub const UNRESTRICTED_CLAMPED: [f32; 2] = [-20.0, 1.45];

/// `depth-range-unrestricted` (needs `VK_EXT_depth_range_unrestricted` and `depthClamp`): the
/// overlap scene with depth outside [0, 1] everywhere, as the extension allows. The pass clears
/// depth to 1.5; the world is drawn with viewport depth [-20, 1.5] (its standard depths 0.967
/// to 0.991 land on 0.79 to 1.31, across 1); a cube floating in front of the far cube is drawn
/// at [1.2, 1.4], behind every world surface (about 1.39 and more), so it shows only against
/// the background (the clear, 1.5); a large cube 150 away, beyond the far plane (100), is drawn
/// with depth clamping at [-20, 1.45]: not clipped, its depth clamped to 1.45, it shows
/// against the background too. On a UNORM format every value is clamped to [0, 1] (the clear
/// to 1, so the squeezed and the clamped cube, at 1, fail LESS against it and vanish).
///
/// Layer items: depth outside [0, 1] in viewports (flip path [a, b] -> [1 - a, 1 - b], precise
/// path unclamped), clears and copies (read back unclamped on a float image); no promotion of
/// UNORM images on such a device (a float format would keep values the UNORM one clamps); in
/// infinite mode, depth stored as complementary mode stores it (infinite mode's n / w cannot
/// follow depth beyond 1: [`depth_range_unrestricted_clear_one`]).
pub fn depth_range_unrestricted() -> Scene {
    unrestricted_scene("depth-range-unrestricted", UNRESTRICTED_CLEAR)
}

/// `depth-range-unrestricted-clear-one`: `depth-range-unrestricted` cleared to 1.0. The world's
/// surfaces whose depth its viewport [-20, 1.5] carries beyond 1 (the far part of the ground
/// and the far cube) fail LESS against the clear and vanish, as do the squeezed cube
/// ([1.2, 1.4]) and the clamped one (1.45).
///
/// Layer item: infinite mode without a far plane would store the clear as 0 and n / w for
/// those surfaces, which then pass: on a device with `VK_EXT_depth_range_unrestricted` revz
/// stores depth as complementary mode does, far plane kept, in infinite mode too.
pub fn depth_range_unrestricted_clear_one() -> Scene {
    unrestricted_scene("depth-range-unrestricted-clear-one", 1.0)
}

/// The scene of [`depth_range_unrestricted`], named `name`, cleared to `clear`.
fn unrestricted_scene(name: &'static str, clear: f32) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let world = b.nearest_first(&camera, overlap_objects());
    let squeezed = b.object(Object::world(
        "squeezed cube",
        Mesh::cuboid(DVec3::splat(0.35)),
        DMat4::from_translation(DVec3::new(-1.7, 1.95, -1.9)) * DMat4::from_rotation_y(0.5),
        rgb8(0, 230, 230),
    ));
    // 150 from the eye (0, 2, 6), 5 degrees above the horizon, straight ahead: beyond the far
    // plane, above the scene.
    let beyond = b.object(Object::world(
        "cube beyond the far plane",
        Mesh::cuboid(DVec3::splat(12.0)),
        DMat4::from_translation(DVec3::new(0.0, 15.0, -140.0)) * DMat4::from_rotation_y(0.3),
        rgb8(240, 200, 40),
    ));
    b.pass(PassSpec::clear(clear));
    let ranged = |name, [min_depth, max_depth]: [f32; 2]| PipelineSpec {
        viewport: Viewport::Static {
            min_depth,
            max_depth,
        },
        ..PipelineSpec::standard(name, 0)
    };
    let world_pipeline = b.pipeline(ranged("world", UNRESTRICTED_WORLD));
    let squeezed_pipeline = b.pipeline(ranged("squeezed", UNRESTRICTED_SQUEEZED));
    let clamped = b.pipeline(PipelineSpec {
        depth_clamp: true,
        ..ranged("clamped", UNRESTRICTED_CLAMPED)
    });
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(world_pipeline));
    b.draw(&world);
    b.step(Step::Bind(squeezed_pipeline));
    b.step(Step::Draw(squeezed));
    b.step(Step::Bind(clamped));
    b.step(Step::Draw(beyond));
    b.step(Step::EndPass);
    b.finish(name, camera, None)
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
