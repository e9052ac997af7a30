//! End-to-end tests of the deliveries that need what Mesa 22.3's lavapipe lacks (issue #41):
//!
//! - `--delivery shader-objects` binds the flat program as unlinked vertex and fragment shader
//!   objects (`VK_EXT_shader_object`) and sets every state of the pipeline it replaces
//!   dynamically, as engines built on shader objects do. Its push-constant ranges get revz's
//!   carrier as a pipeline layout's do, so revz gives the vertex shader a variant storing
//!   `Position` through the pushed carrier (`layer/src/hooks/shader_object.rs`), binds it for
//!   precise-path draws and classifies each pushed matrix on the CPU, as for pipelines.
//! - `--delivery linked-shader-objects` creates those two shaders linked, in one
//!   `vkCreateShadersEXT` call with `VK_SHADER_CREATE_LINK_STAGE_BIT_EXT`: revz sends the set
//!   down unlinked (and its variant with it), so that its vertex shader's variant can be bound
//!   alone; the renders are `shader-objects`' (session 34; before, a linked set took the flip
//!   path).
//! - `--delivery mesh` applies the flat program's pushed MVP in a mesh shader
//!   (`VK_EXT_mesh_shader`, `shaders/glslang/mesh.mesh`) that fetches each draw's triangles
//!   from storage buffers and stores each vertex's `gl_MeshVerticesEXT[i].gl_Position` in a
//!   loop. revz rewrites each such store where it is, with the range the stage fits from the
//!   matrix it loads (`layer/src/shader/position_store`), and classifies that pushed matrix on
//!   the CPU as it does a vertex stage's.
//! - `--delivery mesh-shader-objects` binds that mesh shader as a shader object (both
//!   extensions), which takes the same pushed route: a variant fitting the matrix it loads
//!   and reading the pushed carrier, its matrix classified on the CPU where it is a camera's.
//! - `--delivery linked-tessellation-shader-objects` creates `ubo-tessellation`'s four shaders
//!   (the projection in a uniform buffer, applied in the tessellation evaluation shader) as
//!   one linked set of shader objects: its evaluation shader declares every tessellation mode
//!   itself (glslang's), so revz sends the set down unlinked and gives the evaluation shader
//!   its variant with the carrier baked in (session 35; before, a linked set with tessellation
//!   stages kept its link and took the flip path). Its images are the `ubo-tessellation`
//!   pipelines', without revz and in every mode.
//! - `--delivery passthrough-geometry-shader-objects` binds `ubo-passthrough-geometry`'s three
//!   shaders as unlinked shader objects: the geometry shader passes the vertex shader's
//!   positions through, so revz leaves it as it is and binds the vertex shader's variant for
//!   precise-path draws (session 34, rendered since session 35). Its images are the
//!   `ubo-passthrough-geometry` pipelines', without revz and in every mode.
//! - `--delivery projecting-geometry-shader-objects` binds `ubo-geometry`'s three shaders as
//!   unlinked shader objects: the vertex shader hands `vec4(p, 1.0)` on and the geometry
//!   shader projects `gl_in[i].gl_Position` with the uniform buffer's matrices. Shader objects
//!   pair only at draw time, so revz makes the geometry shader's variant assuming w = 1 and
//!   binds it only after a vertex shader storing w = 1 (session 39; before, such a shader took
//!   the flip path). Its images are the `ubo-geometry` pipelines', without revz and in every
//!   mode.
//!
//! These render on the newer lavapipe `cargo xtask setup` extracts beside the system's on
//! Debian 12 (Mesa 25.0 from bookworm-backports, [`Harness::newer_lavapipe`]), or on the
//! system's own where that is new enough. The installed validation layer (1.3.239) predates
//! `VK_EXT_shader_object`: it rejects the extension's feature structure and hides its dynamic
//! state commands, so the tester renders shader objects without it and says so in
//! `render.json` (`validation_skipped`); the tests check that it says so, and where a newer
//! layer runs, that it counts no message. Mesh shaders render under validation, synchronization
//! validation included, with no message.
//!
//! - `without_the_layer_the_extension_deliveries_render_the_pipelines_image`: the scenes'
//!   images are those of the flat program's pipelines (those of the same shaders for the
//!   buffer deliveries' shader objects): bit for bit through shader objects (the same shaders); through the mesh shader, lavapipe's code for the mesh stage rounds
//!   some products differently, so depth may move by an ulp or two at a few pixels (measured:
//!   188 of 19,200 pixels of `plane-stack`, 1 or 2 ulps), while colors stay the same
//!   (`sloped-plane`, `overlap`), except on `plane-stack`, whose planes lie closer than
//!   standard depth resolves, which plane wins moves with them (44 pixels; its wrong-pixel
//!   fraction is held to the pipelines' in the report test).
//! - `the_extension_deliveries_take_the_precise_path_in_every_precise_mode_and_format`: the
//!   accuracy report of the hard cases in every mode and format. In `complementary` and
//!   `infinite` (D16/D24 promoted to float32) `sloped-plane` and `mars-patch` have no wrong
//!   pixel (17.5% and 3.1% without revz on D32), which the flip path cannot give;
//!   `plane-stack` resolves, at every distance, separations within a factor of 2 of the
//!   float32 model's; `far-objects` has under 0.5% wrong; `deep-range` has none: the pushed
//!   matrices are classified on the CPU (the mesh shader's like a vertex stage's). Shader
//!   objects render their pipelines' images in every mode: the same wrong pixels, to the
//!   pixel count (before session 32 they fitted each object's matrix in the stage:
//!   `deep-range` 18.6%, docs/precise.md).
//!   `flip` and no layer read what the pipelines read (the mesh shader: within 2% of it, for
//!   the ulps above).
//! - `overlap_keeps_the_native_colors_through_the_extension_deliveries_in_every_mode`: the
//!   colors of the render without revz, in `flip`, `complementary` and `infinite`, and the
//!   log line of the precise path in the precise modes.

use std::path::Path;

use revz_tests::{differing_pixels, native_colors_problems, Harness, Render};

/// The deliveries, and the debug log line that says a precise-path stage was made for each.
const DELIVERIES: [(&str, &str); 7] = [
    ("shader-objects", "stores its depth for precise-path draws"),
    (
        "linked-shader-objects",
        "stores its depth for precise-path draws",
    ),
    (
        "mesh",
        "its mesh stage, which derives the range from the matrix it loads",
    ),
    (
        "mesh-shader-objects",
        "stores its depth for precise-path draws",
    ),
    (
        "linked-tessellation-shader-objects",
        "stores its depth for precise-path draws",
    ),
    (
        "passthrough-geometry-shader-objects",
        "passes the positions of the stage before it through",
    ),
    (
        "projecting-geometry-shader-objects",
        "where the stage bound before it stores w = 1",
    ),
];

/// Whether `delivery` binds shader objects (rendered without the installed validation layer,
/// which predates them).
fn binds_shader_objects(delivery: &str) -> bool {
    delivery.ends_with("shader-objects")
}

/// The delivery of pipelines whose shaders `delivery` binds as shader objects: its images are
/// theirs, in every mode.
fn pipeline_twin(delivery: &str) -> Option<&'static str> {
    match delivery {
        "shader-objects" | "linked-shader-objects" => Some("push"),
        "mesh-shader-objects" => Some("mesh"),
        "linked-tessellation-shader-objects" => Some("ubo-tessellation"),
        "passthrough-geometry-shader-objects" => Some("ubo-passthrough-geometry"),
        "projecting-geometry-shader-objects" => Some("ubo-geometry"),
        _ => None,
    }
}

/// The pipelines whose image `delivery` renders without revz and in `flip`: those of the same
/// shaders for the buffer deliveries' shader objects, the flat program's (`push`) for the
/// others.
fn reference_pipelines(delivery: &str) -> &'static str {
    match delivery {
        "linked-tessellation-shader-objects" => "ubo-tessellation",
        "passthrough-geometry-shader-objects" => "ubo-passthrough-geometry",
        "projecting-geometry-shader-objects" => "ubo-geometry",
        _ => "push",
    }
}

/// Whether `delivery` projects in a mesh shader (whose rounding lavapipe makes its own).
fn meshes(delivery: &str) -> bool {
    delivery.starts_with("mesh")
}

/// What the tester says where it left validation out ([`Harness`] renders ask for it).
const SKIPPED: &str = "predates VK_EXT_shader_object";

/// The accuracy scenes these deliveries take.
const SCENES: [&str; 5] = [
    "sloped-plane",
    "mars-patch",
    "plane-stack",
    "deep-range",
    "far-objects",
];

fn render(harness: &Harness, scene: &str, delivery: &str, mode: Option<&str>) -> Render {
    let label = mode.unwrap_or("native");
    let dir = harness.scratch_dir(&format!("extension-deliveries-{scene}-{delivery}-{label}"));
    let mut command = harness.tester("d32", &dir);
    command
        .args([
            "--scene",
            scene,
            "--delivery",
            delivery,
            "--sync-validation",
        ])
        .args(["--width", "160", "--height", "120"]);
    harness.on_newer_lavapipe(&mut command);
    if let Some(mode) = mode {
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", mode)
            .env("REVZ_LOG", "debug");
    }
    let render = harness.render(command, &dir);
    let json = render.json();
    assert_validation_accounted(
        delivery,
        &json["validation_skipped"],
        &format!("{scene} {delivery} {label}: {json}"),
    );
    assert_eq!(json["validation_messages"], 0, "{scene} {delivery} {label}");
    render
}

/// Validation ran, or (shader objects only) the render says why it did not.
fn assert_validation_accounted(delivery: &str, skipped: &serde_json::Value, what: &str) {
    match skipped.as_str() {
        None => {}
        Some(why) if binds_shader_objects(delivery) => assert!(why.contains(SKIPPED), "{what}"),
        Some(_) => panic!("validation skipped: {what}"),
    }
}

#[test]
fn without_the_layer_the_extension_deliveries_render_the_pipelines_image() {
    let harness = Harness::locate();
    for scene in ["sloped-plane", "plane-stack", "overlap"] {
        let references: Vec<(&str, Render)> = [
            "push",
            "ubo-tessellation",
            "ubo-passthrough-geometry",
            "ubo-geometry",
        ]
        .into_iter()
        .map(|pipelines| (pipelines, render(&harness, scene, pipelines, None)))
        .collect();
        for (delivery, _) in DELIVERIES {
            let pipelines = references
                .iter()
                .find(|(name, _)| *name == reference_pipelines(delivery))
                .map(|(_, render)| render)
                .expect("the reference pipelines' render");
            let other = render(&harness, scene, delivery, None);
            let (a, b) = (pipelines.depth(), other.depth());
            assert_eq!(a.len(), b.len());
            let ulps = |x: f32, y: f32| (i64::from(x.to_bits()) - i64::from(y.to_bits())).abs();
            let differing: Vec<usize> = (0..a.len()).filter(|&i| a[i] != b[i]).collect();
            if meshes(delivery) {
                assert!(
                    differing.iter().all(|&i| ulps(a[i], b[i]) <= 2),
                    "{scene} mesh: depth more than 2 ulps apart"
                );
                assert!(
                    differing.len() * 50 <= a.len(),
                    "{scene} mesh: depth differs at {} pixels",
                    differing.len()
                );
                // `plane-stack` stacks planes closer than standard depth resolves: where their
                // depths are an ulp apart, which wins moves with the ulps (its wrong-pixel
                // fraction is compared in the report test). Elsewhere: the same colors.
                if scene != "plane-stack" {
                    assert_eq!(
                        differing_pixels(&pipelines.color(), &other.color()),
                        0,
                        "{scene} mesh: colors"
                    );
                }
            } else {
                assert_eq!(differing.len(), 0, "{scene} {delivery}: depth values");
                assert_eq!(
                    differing_pixels(&pipelines.color(), &other.color()),
                    0,
                    "{scene} {delivery}: colors"
                );
            }
        }
    }
}

fn report(harness: &Harness, out: &Path) -> serde_json::Value {
    let scenes = SCENES.join(",");
    let args = [
        "--scenes",
        &scenes,
        "--modes",
        "none,flip,complementary,infinite",
        "--formats",
        "d16,x8-d24,d24-s8,d32,d32-s8",
        "--deliveries",
        "push,shader-objects,linked-shader-objects,mesh,mesh-shader-objects,ubo-tessellation,\
         linked-tessellation-shader-objects,ubo-passthrough-geometry,\
         passthrough-geometry-shader-objects,ubo-geometry,projecting-geometry-shader-objects",
    ];
    harness.report(out, &args, true)
}

#[test]
fn the_extension_deliveries_take_the_precise_path_in_every_precise_mode_and_format() {
    let harness = Harness::locate();
    let out = harness.scratch_dir("extension-deliveries-report");
    let report = report(&harness, &out);
    let rows = report["rows"].as_array().expect("rows");
    let separations = report["min_separation"].as_array().expect("min_separation");
    let find = |scene: &str, delivery: &str, mode: &str, format: &str| {
        rows.iter()
            .find(|r| {
                r["scene"] == scene
                    && r["delivery"] == delivery
                    && r["mode"] == mode
                    && r["format"] == format
            })
            .unwrap_or_else(|| panic!("no row {scene} {delivery} {mode} {format}"))
    };
    let fraction = |r: &serde_json::Value| r["wrong_pixel_fraction"].as_f64().unwrap();
    let mut problems = Vec::new();
    for (delivery, _) in DELIVERIES {
        for scene in SCENES {
            for format in ["d16", "x8-d24", "d24-s8", "d32", "d32-s8"] {
                for mode in ["none", "flip", "complementary", "infinite"] {
                    let r = find(scene, delivery, mode, format);
                    let what = format!("{delivery} {scene} {mode} {format}");
                    assert!(r["error"].is_null(), "{what}: {r}");
                    assert!(r["checked_pixels"].as_u64().unwrap() > 3000, "{what}: {r}");
                    assert_validation_accounted(delivery, &r["validation_skipped"], &what);
                    let own = fraction(r);
                    let pipelines =
                        fraction(find(scene, reference_pipelines(delivery), mode, format));
                    let native = fraction(find(scene, delivery, "none", format));
                    eprintln!(
                        "{what}: {own:.3e} wrong (pipelines {pipelines:.3e}, no revz \
                         {native:.3e})"
                    );
                    match mode {
                        // The same depth path as the pipelines: the same image (the mesh
                        // shader's, within its ulps: module docs).
                        "none" | "flip"
                            if (own - pipelines).abs()
                                > if meshes(delivery) {
                                    0.02 * pipelines
                                } else {
                                    0.0
                                } =>
                        {
                            problems.push(format!(
                                "{what}: {own:.3e} wrong against the pipelines' {pipelines:.3e}"
                            ))
                        }
                        // The float32 floor: the minimum separation resolved at each distance
                        // within a factor of 2 of the model's (as for the push delivery).
                        // The shader objects' pushed route is the pipelines' path: the same
                        // count of wrong pixels as the pipelines of the same shaders.
                        "complementary" | "infinite"
                            if pipeline_twin(delivery).is_some_and(|twin| {
                                fraction(find(scene, twin, mode, format)) != own
                            }) =>
                        {
                            problems.push(format!(
                                "{what}: {own:.3e} wrong, not the {:?} pipelines' count",
                                pipeline_twin(delivery)
                            ))
                        }
                        "complementary" | "infinite" if scene == "plane-stack" => {
                            let points: Vec<&serde_json::Value> = separations
                                .iter()
                                .filter(|s| {
                                    s["delivery"] == delivery
                                        && s["mode"] == mode
                                        && s["format"] == format
                                })
                                .collect();
                            if points.len() != 6 || points.iter().any(|s| s["agrees"] != true) {
                                problems.push(format!(
                                    "{what}: the minimum separation misses the model: {points:?}"
                                ));
                            }
                        }
                        "complementary" | "infinite" => {
                            let bound = match scene {
                                "sloped-plane" | "mars-patch" => 0.0,
                                "far-objects" => 0.005,
                                _ => 0.0,
                            };
                            if own > bound {
                                problems.push(format!(
                                    "{what}: {own:.3e} wrong, above {bound:.3e} (no revz \
                                     {native:.3e}, pipelines {pipelines:.3e})"
                                ));
                            }
                        }
                        _ => {}
                    }
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn overlap_keeps_the_native_colors_through_the_extension_deliveries_in_every_mode() {
    let harness = Harness::locate();
    let mut problems = Vec::new();
    for (delivery, precise_line) in DELIVERIES {
        let native = render(&harness, "overlap", delivery, None);
        let truth = native.ground_truth();
        for mode in ["flip", "complementary", "infinite"] {
            let layered = render(&harness, "overlap", delivery, Some(mode));
            let what = format!("overlap {delivery} {mode}");
            problems.extend(native_colors_problems(&native, &layered, &truth, &what));
            let log = layered.stderr();
            if mode != "flip" && !log.contains(precise_line) {
                problems.push(format!("{what}: no precise-path stage: {log}"));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
