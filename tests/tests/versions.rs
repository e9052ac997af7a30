//! Applications that ask for Vulkan 1.0 or 1.1 (issue #18): revz must enable what it needs with
//! its requirements at every API version (`VK_EXT_extended_dynamic_state`, and below 1.1 the
//! `VK_KHR_get_physical_device_properties2` it requires), so that every scene renders in every
//! mode with zero validation messages, and exactly as it does for a Vulkan 1.3 application.
//!
//! Each scene is rendered through the layer (`reverse_observable = copies`, so its main depth
//! image is reversed and read back) at 1.3, then at 1.0 and 1.1: color and depth must be
//! bit-identical to the 1.3 render, whose correctness the other suites check. Scenes that use
//! later core commands get them, as older applications do, from the extensions that gave them
//! before (`VK_KHR_dynamic_rendering`, `VK_EXT_extended_dynamic_state`,
//! `VK_KHR_create_renderpass2` with `VK_KHR_depth_stencil_resolve`), so every scene runs at
//! every version; only `depth-bounds` is refused (lavapipe lacks the feature), and the
//! local-read scenes below Vulkan 1.3 (the tester asks for
//! `VK_KHR_dynamic_rendering_local_read` at 1.3 only; they render on the newer lavapipe), and
//! that is asserted, not skipped silently.

use std::path::Path;

use revz_tests::{differing_depths, differing_pixels, Harness, Render};

/// The scenes `revz-tester --help` lists under `--scene`.
fn scenes(harness: &Harness) -> Vec<String> {
    let output = revz_tests::clean_command(&harness.tester)
        .arg("--help")
        .output()
        .expect("run revz-tester --help");
    let help = String::from_utf8_lossy(&output.stdout).into_owned();
    let section = help
        .split("--scene <SCENE>")
        .nth(1)
        .and_then(|rest| rest.split("\n      --").next())
        .expect("--help documents --scene");
    let scenes: Vec<String> = section
        .lines()
        .filter_map(|line| line.trim().strip_prefix("- "))
        .filter_map(|entry| entry.split(':').next())
        .map(str::to_owned)
        .collect();
    assert!(
        scenes.len() >= 30 && scenes.iter().any(|s| s == "overlap"),
        "{scenes:?}"
    );
    scenes
}

/// The scenes the tester refuses, and why (what its error says).
fn refused(version: &str, scene: &str) -> Option<&'static str> {
    if scene == "depth-bounds" {
        // lavapipe has no depthBounds.
        return Some("device lacks depthBounds");
    }
    // The tester asks for `VK_KHR_dynamic_rendering_local_read` at Vulkan 1.3 only (with
    // `dynamicRendering`, which it requires).
    (LOCAL_READ_SCENES.contains(&scene) && version != "1.3")
        .then_some("device lacks dynamicRenderingLocalRead")
}

/// Scenes that read depth locally in dynamic rendering: rendered on the newer lavapipe where
/// there is one ([`Harness::newer_lavapipe`]; Mesa 22.3's lacks the extension).
const LOCAL_READ_SCENES: [&str; 3] = [
    "deferred-depth-local-read",
    "deferred-depth-local-read-indexed",
    "deferred-depth-local-read-tested",
];

/// The scenes whose device extensions (`VK_EXT_depth_clip_control`,
/// `VK_EXT_graphics_pipeline_library`, `VK_KHR_push_descriptor`, and below their core versions the extensions of dynamic
/// rendering, the dynamic compare op and depth resolves) make the tester, as a Vulkan 1.0
/// application, enable `VK_KHR_get_physical_device_properties2` itself: revz then has nothing
/// to add.
const ENABLE_PROPERTIES2_THEMSELVES: [&str; 22] = [
    "opengl-depth",
    "pipeline-library",
    "frag-depth-library",
    "pipeline-library-dynamic",
    "frag-depth-library-dynamic",
    "deferred-depth-library",
    "deferred-depth-tested-library",
    "compare-ops-dynamic",
    "dynamic-rendering",
    "dynamic-rendering-suspended",
    "dynamic-rendering-suspended-across",
    "dynamic-rendering-secondaries",
    "msaa-resolve",
    "msaa-resolve-dynamic",
    // VK_ATTACHMENT_STORE_OP_NONE for its read-only depth attachment, through
    // VK_KHR_dynamic_rendering below 1.3, and VK_KHR_push_descriptor (asked for by the scenes
    // with a post pass, used where the device has it).
    "depth-reads",
    "stencil-reads",
    "depth-mips",
    "depth-layers",
    "depth-layers-stepwise",
    "depth-reads-msaa",
    // VK_KHR_multiview below 1.1.
    "multiview",
    "multiview-dynamic",
];

/// Scenes whose draws are recorded into secondaries on several threads at once: in a camera's
/// first frame, the range its draws store depth with is that of the first of its matrices any
/// recording met (`revz::precise::FirstSeen`, session 39), which depends on thread timing, so
/// two runs' first-frame depths may differ by that matrix's error bound (their colors do not).
/// They are compared in their second frame, which every recording begins from the device's
/// best range of the camera.
const THREADED_SCENES: [&str; 5] = [
    "threads",
    "shadow-map-secondaries",
    "shadow-map-perspective-secondaries",
    "deferred-depth-secondaries",
    "dynamic-rendering-secondaries",
];

/// The scenes that set the compare op dynamically: below 1.3 the tester enables
/// `VK_EXT_extended_dynamic_state` itself, and revz must not add it again.
const ENABLE_EXTENDED_DYNAMIC_STATE_THEMSELVES: [&str; 1] = ["compare-ops-dynamic"];

/// Renders `scene` through the layer in `mode` at `version`; `Err` with the tester's error
/// where it refused the scene.
fn render(harness: &Harness, scene: &str, mode: &str, version: &str) -> Result<Render, String> {
    let format = if matches!(scene, "stencil" | "stencil-reads") {
        "d32-s8"
    } else {
        "d32"
    };
    let dir = harness.scratch_dir(&format!("versions-{scene}-{mode}-{version}"));
    let mut command = harness.tester(format, &dir);
    command.args(["--scene", scene, "--vulkan", version]);
    if THREADED_SCENES.contains(&scene) {
        command.args(["--frames", "2"]);
    }
    if LOCAL_READ_SCENES.contains(&scene) {
        harness.on_newer_lavapipe(&mut command);
    }
    harness
        .with_layer(&mut command)
        .env("REVZ_MODE", mode)
        .env("REVZ_REVERSE_OBSERVABLE", "copies")
        .env("REVZ_COPY_VALUES", "stored")
        .env("REVZ_LOG", "info");
    let output = command.output().expect("start revz-tester");
    let render = Render { dir, output };
    if render.output.status.code() == Some(1) {
        return Err(render.stderr());
    }
    render.assert_clean();
    Ok(render)
}

fn same_as_vulkan_1_3(mode: &str) {
    let harness = Harness::locate();
    let mut problems = Vec::new();
    for scene in scenes(&harness) {
        let reference = render(&harness, &scene, mode, "1.3");
        for version in ["1.3", "1.0", "1.1"] {
            let result = if version == "1.3" {
                reference.as_ref().map(|_| ()).map_err(Clone::clone)
            } else {
                render(&harness, &scene, mode, version).and_then(|layered| {
                    check(&layered, reference.as_ref().ok(), &scene, mode, version)
                        .map_err(|problem| format!("RENDERED: {problem}"))
                })
            };
            match (refused(version, &scene), result) {
                (None, Ok(())) => {}
                (Some(reason), Err(error)) if error.contains(reason) => {}
                (expected, outcome) => problems.push(format!(
                    "{scene} {mode} at Vulkan {version}: expected {}, got {outcome:?}",
                    expected.map_or("a clean render".to_owned(), |r| format!("refusal '{r}'"))
                )),
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The render at an older version against the 1.3 one.
fn check(
    layered: &Render,
    reference: Option<&Render>,
    scene: &str,
    mode: &str,
    version: &str,
) -> Result<(), String> {
    let stderr = layered.stderr();
    let added = "enabled VK_KHR_get_physical_device_properties2";
    let should_add =
        mode != "off" && version == "1.0" && !ENABLE_PROPERTIES2_THEMSELVES.contains(&scene);
    if stderr.contains(added) != should_add {
        return Err(format!(
            "'{added}' expected: {should_add}; the log:\n{stderr}"
        ));
    }
    let added = "enabled VK_EXT_extended_dynamic_state";
    let should_add = mode != "off" && !ENABLE_EXTENDED_DYNAMIC_STATE_THEMSELVES.contains(&scene);
    if stderr.contains(added) != should_add {
        return Err(format!(
            "'{added}' expected: {should_add}; the log:\n{stderr}"
        ));
    }
    let Some(reference) = reference else {
        return Err("the Vulkan 1.3 render was refused".into());
    };
    let colors = differing_pixels(&reference.color(), &layered.color());
    let depths = if Path::new(&layered.dir.join("depth.f32")).exists() {
        differing_depths(&reference.depth(), &layered.depth())
    } else {
        0
    };
    if colors != 0 || depths != 0 {
        return Err(format!(
            "{colors} color pixels and {depths} depth values differ from Vulkan 1.3"
        ));
    }
    Ok(())
}

#[test]
fn off_at_vulkan_1_0_and_1_1_renders_as_at_1_3() {
    same_as_vulkan_1_3("off");
}

#[test]
fn flip_at_vulkan_1_0_and_1_1_renders_as_at_1_3() {
    same_as_vulkan_1_3("flip");
}

#[test]
fn complementary_at_vulkan_1_0_and_1_1_renders_as_at_1_3() {
    same_as_vulkan_1_3("complementary");
}

#[test]
fn infinite_at_vulkan_1_0_and_1_1_renders_as_at_1_3() {
    same_as_vulkan_1_3("infinite");
}
