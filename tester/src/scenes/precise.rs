//! The scenes of the precise path: the overlap scene, or one like it, with its projection
//! handed to the shader another way (projection alone, view-projection, model-view-projection
//! pairs, row-major, OpenGL depth, already reversed, partial pushes, threads, lit boxes).

use super::*;

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
