//! revz's depth profile (issue #19, `layer/src/profile.rs`): for every tester scene in every
//! mode, the profile written with `REVZ_REPORT` says exactly what the scene does (the draws
//! per path, per depth image and per pipeline, the reversed and native depth images with their
//! reasons, the cameras with the scene's range), judged against what the tester recorded and
//! the scene's description; and a killed process leaves a valid profile.

use std::time::{Duration, Instant};

use revz_tests::{clean_command, Harness, Render};
use serde_json::Value;

/// Renders `scene` through revz in `mode` (no depth readback, so the depth image may be
/// reversed) with its profile written to a file: the render's `render.json` and the
/// profile, or `None` where the tester refuses the scene for a feature lavapipe lacks.
/// Scenes rendered on the newer lavapipe where there is one ([`Harness::newer_lavapipe`]):
/// Mesa 22.3's lacks `VK_KHR_dynamic_rendering_local_read`.
const NEWER_LAVAPIPE_SCENES: [&str; 3] = [
    "deferred-depth-local-read",
    "deferred-depth-local-read-indexed",
    "deferred-depth-local-read-tested",
];

fn profiled(harness: &Harness, scene: &str, delivery: &str, mode: &str) -> Option<(Value, Value)> {
    let dir = harness.scratch_dir(&format!("profile-{scene}-{delivery}-{mode}"));
    let report = dir.join("revz-profile.json");
    std::fs::remove_file(&report).ok();
    // The stencil scene needs a stencil aspect; every other scene renders D32.
    let format = if matches!(scene, "stencil" | "stencil-reads") {
        "d32-s8"
    } else {
        "d32"
    };
    let mut command = harness.tester(format, &dir);
    command
        .args([
            "--scene",
            scene,
            "--delivery",
            delivery,
            "--no-depth-readback",
        ])
        .env("REVZ_MODE", mode)
        .env("REVZ_REPORT", &report);
    if NEWER_LAVAPIPE_SCENES.contains(&scene) {
        harness.on_newer_lavapipe(&mut command);
    }
    harness.with_layer(&mut command);
    let output = command.output().expect("start revz-tester");
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !output.status.success() && scene == "depth-bounds" && stderr.contains("lacks depthBounds") {
        return None;
    }
    let render = Render { dir, output };
    render.assert_clean();
    // The tester prints the profile's summary at its end.
    assert!(
        render.stdout().contains("revz: precise "),
        "{}",
        render.stdout()
    );
    let profile: Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("the profile")).unwrap();
    Some((render.json(), profile))
}

/// (precise, flip, native) of a profile's `draws` object.
fn paths(draws: &Value) -> (u64, u64, u64) {
    let n = |k: &str| draws[k].as_u64().unwrap();
    (n("precise"), n("flip"), n("native"))
}

/// `VK_IMAGE_USAGE_SAMPLED_BIT`: shaders sample the image, which under the default
/// `reverse_observable` they do through its read twin where it has one sample.
const SAMPLED: u64 = 0x4;
/// `VK_IMAGE_USAGE_STORAGE_BIT`: shaders write the image, which no twin can serve: its depth
/// stays standard.
const STORAGE: u64 = 0x8;
/// `VK_IMAGE_USAGE_INPUT_ATTACHMENT_BIT`: shaders read the image inside the pass that writes
/// it; revz converts those reads in the shader (in `infinite` the image stores complementary
/// depth for it).
const INPUT_ATTACHMENT: u64 = 0x80;

/// What the profile must say of one render, derived from what the tester recorded
/// (`render.json`'s `recorded`: its depth images with their usage, its draws per pipeline
/// and image, with the handles revz saw) and the scene's own description (its clear depth,
/// camera and pipelines), never from the profile itself:
///
/// - every recorded depth image is listed with its format, size and samples; it is native
///   where shaders read it in a way neither a read twin nor a shader rewrite serves (storage,
///   an input attachment in `infinite` mode, a
///   multisampled image sampled) or where the application renders reversed depth itself (a
///   scene that clears to 0), and reversed otherwise; a sampled single-sampled image has a
///   read twin (issue #39);
/// - every draw is counted once, under its image and its pipeline: into a native image it is
///   native; into a reversed one it is flip in `flip` mode, and in the precise modes precise,
///   except the draws into an orthographic light's shadow map (flip), the draws of a
///   pipeline with a constant viewport depth (a sky at [1, 1]: no
///   precision to gain, flip), of a pipeline that does not test depth (nothing compares its
///   depth: flip); a program whose push constants fill the 128 bytes (`MvpPair`: no room for
///   revz's carrier) takes the precise path with the range its stage fits (issue #41);
/// - the cameras: none in `flip` mode or for buffer deliveries (their range is fitted by the
///   vertex stage); in the precise modes with push constants (read on the CPU from a vertex
///   stage's, and from a geometry stage's that loads the matrix whole: `push-geometry`, whose
///   stage also fits it, issue #41), each camera's near plane is
///   the one a pushed float32 matrix holds (computed in f64 by the tester), near the scene's,
///   and together the cameras matched at least one matrix and no more than the draws.
fn check(scene: &str, delivery: &str, mode: &str, render: &Value, profile: &Value) {
    let what = format!("{scene} ({delivery}) in {mode}");
    let recorded = &render["recorded"];
    let frames = recorded["frames"].as_u64().unwrap();
    let application_reversed = render["clear_depth"].as_f64() == Some(0.0);
    let unrestricted = render["features"]
        .as_array()
        .is_some_and(|f| f.iter().any(|f| f == "VK_EXT_depth_range_unrestricted"));
    let images = profile["images"].as_array().expect("images");
    let mut native_images = Vec::new();
    for image in recorded["depth_images"].as_array().unwrap() {
        let handle = image["handle"].as_str().unwrap();
        let listed = images
            .iter()
            .find(|i| i["handle"] == handle)
            .unwrap_or_else(|| panic!("{what}: image {image} not in {images:?}"));
        for (field, in_profile) in [
            ("format", "format"),
            ("width", "width"),
            ("height", "height"),
            ("samples", "samples"),
        ] {
            assert_eq!(
                listed[in_profile], image[field],
                "{what}: {field} of {image}"
            );
        }
        // Sampled images are read through a read twin (issue #39) and stay reversed (a
        // multisampled one where the device writes its twin per sample); input attachments
        // too, their reads converted in the shader (in infinite mode such an image stores
        // complementary depth); storage images stay native.
        let usage = image["usage"].as_u64().unwrap();
        let sampled = usage & SAMPLED != 0;
        let storage = usage & STORAGE != 0;
        let input = usage & INPUT_ATTACHMENT != 0;
        // lavapipe writes the twins of 4-sample images per sample (storage R32_SFLOAT images
        // of 1 and 4 samples).
        let twin_samples = image["samples"] == 1 || image["samples"] == 4;
        let reads_follow = !storage && (!sampled || twin_samples);
        let twin = sampled && reads_follow;
        assert_eq!(listed["read_twin"], twin, "{what}: {listed}");
        let read_by_shaders = (sampled || storage || input) && !reads_follow;
        let native = read_by_shaders || application_reversed;
        assert_eq!(
            listed["depth"],
            if native { "native" } else { "reversed" },
            "{what}: {listed}"
        );
        if native {
            native_images.push(image["role"].as_str().unwrap().to_owned());
            let reason = listed["reason"].as_str().unwrap();
            let expected = if read_by_shaders {
                "shaders read it"
            } else {
                "already renders reversed"
            };
            assert!(reason.contains(expected), "{what}: {reason}");
        }
        let drawn: u64 = recorded["draws"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|d| d["image"] == image["role"])
            .map(|d| d["draws"].as_u64().unwrap())
            .sum::<u64>()
            * frames;
        let (precise, flip, native_draws) = paths(&listed["draws"]);
        assert_eq!(
            precise + flip + native_draws,
            drawn,
            "{what}: draws into {image}"
        );
        if native {
            assert_eq!(native_draws, drawn, "{what}: {listed}");
        } else {
            assert_eq!(native_draws, 0, "{what}: {listed}");
        }
    }
    let pipelines = profile["pipelines"].as_array().expect("pipelines");
    let mut expected = (0, 0, 0);
    for draws in recorded["draws"].as_array().unwrap() {
        let handle = draws["handle"].as_str().unwrap();
        let count = draws["draws"].as_u64().unwrap() * frames;
        let into_native = native_images.iter().any(|role| draws["image"] == *role);
        let constant_depth = draws["viewport_depth"]
            .as_array()
            .is_some_and(|range| range[0] == range[1]);
        let no_room = draws["program"] == "MvpPair";
        let untested = draws["depth_test"] == false;
        // The shadow map's light is orthographic (but in `shadow-map-perspective`, a spot
        // light): an affine projection, whose depth the flip path reverses as exactly as a
        // rewrite would (`shared/DESIGN.md` section 1).
        let orthographic =
            draws["image"] == "shadow" && !scene.starts_with("shadow-map-perspective");
        // Infinite mode's precise path removes the far plane, which a clamping pipeline clamps
        // at (issue #44): those take the flip path. Not on a device that enabled
        // VK_EXT_depth_range_unrestricted, where infinite mode reverses as complementary does.
        let clamped = mode == "infinite" && draws["depth_clamp"] == true && !unrestricted;
        let path = if into_native {
            "native"
        } else if mode == "flip" || constant_depth || untested || orthographic || clamped {
            "flip"
        } else {
            "precise"
        };
        match path {
            "precise" => expected.0 += count,
            "flip" => expected.1 += count,
            _ => expected.2 += count,
        }
        let listed = pipelines
            .iter()
            .find(|p| p["handle"] == handle)
            .unwrap_or_else(|| panic!("{what}: pipeline {draws} not in {pipelines:?}"));
        assert_eq!(listed["kind"], "pipeline", "{what}");
        if no_room && mode != "flip" && path == "precise" {
            // Fitted by its stage, the carrier baked into its reversed variant.
            let projection = listed["projection"].as_str().unwrap();
            assert!(projection.contains("fitted"), "{what}: {listed}");
            assert_eq!(listed["reversed_variant"], true, "{what}: {listed}");
        }
        if clamped {
            assert_eq!(listed["path"], "flip", "{what}: {listed}");
            let why = listed["projection"].as_str().unwrap();
            assert!(why.contains("clamps depth"), "{what}: {why}");
        }
        let pushes = matches!(delivery, "push" | "push-split");
        if !pushes && mode != "flip" {
            let projection = listed["projection"].as_str().unwrap();
            assert!(projection.contains("fitted"), "{what}: {listed}");
        }
        // Every recorded draw of this pipeline, whatever image it went to.
        let all: u64 = recorded["draws"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|d| d["handle"] == handle)
            .map(|d| d["draws"].as_u64().unwrap())
            .sum::<u64>()
            * frames;
        let (precise, flip, native) = paths(&listed["draws"]);
        assert_eq!(precise + flip + native, all, "{what}: {listed}");
        if path == "precise" {
            assert!(precise >= count, "{what}: {listed}");
        }
    }
    // Draws into no depth image (a post pass over color) count in the totals, and apart in
    // `draws_without_depth_image`; the census leaves them out.
    let (p, f, n) = paths(&profile["totals"]["draws"]);
    let (p0, f0, n0) = paths(&profile["totals"]["draws_without_depth_image"]);
    assert_eq!((p - p0, f - f0, n - n0), expected, "{what}");
    // The flip path's draws, shared out by reason (issue #41): all of them, each once.
    let reasons = profile["totals"]["flip_reasons"]
        .as_array()
        .expect("flip_reasons");
    let by_reason: u64 = reasons.iter().map(|r| r["draws"].as_u64().unwrap()).sum();
    assert_eq!(by_reason, expected.1, "{what}: {reasons:?}");
    let flip_pipelines = pipelines.iter().filter(|p| p["path"] == "flip").count();
    let counted: usize = reasons
        .iter()
        .map(|r| r["pipelines"].as_u64().unwrap() as usize)
        .sum();
    assert_eq!(counted, flip_pipelines, "{what}: {reasons:?}");
    assert_eq!(profile["totals"]["frames"], frames, "{what}");
    let cameras = profile["cameras"].as_array().expect("cameras");
    // `MvpPair`'s matrices are not read on the CPU (its stage fits them), nor `Multiview`'s
    // (the views' projections are in a uniform buffer): no camera.
    let cpu_projections = recorded["draws"]
        .as_array()
        .unwrap()
        .iter()
        .any(|d| d["program"] != "MvpPair" && d["program"] != "Multiview");
    let pushed = matches!(delivery, "push" | "push-split" | "push-geometry")
        && mode != "flip"
        && !application_reversed
        && cpu_projections;
    if !pushed || expected.0 == 0 {
        assert!(cameras.is_empty(), "{what}: {cameras:?}");
    } else {
        assert!(!cameras.is_empty(), "{what}");
        // What the pushed float32 matrices hold, computed in f64 by the tester: each camera
        // is one of them (the best-conditioned line revz saw of it).
        let held: Vec<f64> = recorded["matrix_near"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(Value::as_f64)
            .collect();
        let scene_near = render["ground_truth"]["near"].as_f64();
        for camera in cameras {
            assert_eq!(camera["delivered"], "push constants", "{what}");
            let found = camera["near"].as_f64().unwrap();
            // `shadow-map-perspective`'s spot light is a second camera (near 2, the tester's
            // `shadow_light`), whose matrices the tester does not list.
            if scene.starts_with("shadow-map-perspective") && (found / 2.0 - 1.0).abs() < 1e-6 {
                continue;
            }
            assert!(
                held.iter().any(|near| (found / near - 1.0).abs() < 1e-9),
                "{what}: camera near {found}, the matrices hold {held:?}"
            );
            if let Some(near) = scene_near {
                // And the scene's own near plane, to what float32 entries keep of it.
                assert!(
                    (found / near - 1.0).abs() < 0.3,
                    "{what}: {found} vs {near}"
                );
            }
        }
        let matched: u64 = cameras
            .iter()
            .map(|c| c["matrices_matched"].as_u64().unwrap())
            .sum();
        let total = expected.0 + expected.1 + expected.2;
        assert!(
            (1..=total).contains(&matched),
            "{what}: {matched} of {total}"
        );
    }
    let mode_setting = profile["settings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "mode")
        .cloned()
        .unwrap();
    assert_eq!(mode_setting["value"], mode, "{what}");
    assert_eq!(mode_setting["from"], "environment REVZ_MODE", "{what}");
    let summary = profile["summary"].as_str().unwrap();
    let total = (expected.0 + expected.1 + expected.2).max(1) as f64;
    let start = format!("precise {:.0}% of draws", 100.0 * expected.0 as f64 / total);
    assert!(summary.starts_with(&start), "{what}: {summary}");
}

/// The tester's scene names.
fn scenes(harness: &Harness) -> Vec<String> {
    let output = revz_tests::clean_command(&harness.tester)
        .arg("scenes")
        .output()
        .expect("revz-tester scenes");
    assert!(output.status.success());
    String::from_utf8_lossy(&output.stdout)
        .lines()
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_profile_says_what_every_scene_does_in_every_mode() {
    let harness = Harness::locate();
    let scenes = scenes(&harness);
    assert!(scenes.len() >= 38, "{scenes:?}");
    let mut refused = Vec::new();
    for scene in &scenes {
        for mode in ["flip", "complementary", "infinite"] {
            match profiled(&harness, scene, "push", mode) {
                Some((render, profile)) => check(scene, "push", mode, &render, &profile),
                None => refused.push(format!("{scene} {mode}")),
            }
        }
    }
    // Only the depth-bounds scene may be refused, for lavapipe's lack of depthBounds.
    assert!(
        refused.iter().all(|r| r.starts_with("depth-bounds ")),
        "{refused:?}"
    );
}

#[test]
fn the_profile_says_what_buffer_deliveries_do() {
    let harness = Harness::locate();
    for (scene, delivery) in [
        ("overlap", "ubo"),
        ("sloped-plane", "ubo-dynamic"),
        ("far-objects", "ssbo"),
        ("compare-ops", "ubo"),
        ("plane-stack", "ubo-geometry"),
        ("sloped-plane", "ubo-tessellation"),
        ("mars-patch", "ssbo-rows"),
        ("far-objects", "ssbo-registers"),
        ("plane-stack", "push-split"),
        ("sloped-plane", "push-geometry"),
        ("sloped-plane", "push-full"),
    ] {
        for mode in ["flip", "complementary", "infinite"] {
            let (render, profile) =
                profiled(&harness, scene, delivery, mode).expect("lavapipe renders it");
            check(scene, delivery, mode, &render, &profile);
        }
    }
}

#[test]
fn a_read_back_depth_image_stays_reversed_its_copies_are_counted_and_the_profile_reads_as_tables() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("profile-readback");
    let report = dir.join("revz-profile.json");
    std::fs::remove_file(&report).ok();
    let mut command = harness.tester("d32", &dir);
    command
        .args(["--scene", "shadow-map", "--frames", "3"])
        .env("REVZ_MODE", "infinite")
        .env("REVZ_REPORT", &report);
    harness.with_layer(&mut command);
    let render = harness.render(command, &dir);
    let profile: Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("the profile")).unwrap();
    check("shadow-map", "push", "infinite", &render.json(), &profile);
    // One converted readback of the reversed main image per frame.
    let copies = &profile["totals"]["copies_recorded"];
    assert_eq!(copies["converted"], 3, "{copies}");
    assert_eq!(copies["unconverted"], 0, "{copies}");
    // The shadow map is reversed too, read through its twin (issue #39), refreshed once per
    // frame at the end of the shadow pass: 512 x 512 D32 texels each time.
    let images = profile["images"].as_array().unwrap();
    let map = images
        .iter()
        .find(|i| i["width"] == 512)
        .unwrap_or_else(|| panic!("no shadow map: {images:?}"));
    assert_eq!(map["depth"], "reversed", "{map}");
    assert_eq!(map["read_twin"], true, "{map}");
    assert_eq!(map["refreshes_recorded"], 3, "{map}");
    assert_eq!(map["bytes_refreshed"], 3 * 512 * 512 * 4, "{map}");
    let refreshes = &profile["totals"]["read_twin_refreshes_recorded"];
    assert_eq!(refreshes["recorded"], 3, "{refreshes}");
    assert_eq!(refreshes["failed"], 0, "{refreshes}");
    let frames = profile["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    for frame in frames {
        // Every draw is reversed: the main pass's precise, the shadow casters' (an
        // orthographic light) flip.
        assert_eq!(frame["draws"]["native"], 0, "{frame}");
        assert_eq!(frame["draws"]["precise"], frame["draws"]["flip"], "{frame}");
        assert_eq!(frame["precise_fraction_of_reversed"], 0.5, "{frame}");
        assert_eq!(frame["by_image"].as_array().unwrap().len(), 2, "{frame}");
    }
    // `revz-tester profile` renders it as tables and a chart.
    let png = dir.join("profile.png");
    std::fs::remove_file(&png).ok();
    let output = clean_command(&harness.tester)
        .arg("profile")
        .arg(&report)
        .arg("--png")
        .arg(&png)
        .output()
        .expect("revz-tester profile");
    let tables = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{tables}");
    assert!(
        tables.contains("summary: precise 50% of draws (infinite; camera n=0.1)"),
        "{tables}"
    );
    let main = profile["images"]
        .as_array()
        .unwrap()
        .iter()
        .find(|i| i["depth"] == "reversed")
        .unwrap();
    let row = format!("| {} | D32_SFLOAT |", main["handle"].as_str().unwrap());
    let line = tables
        .lines()
        .find(|l| l.starts_with(&row))
        .expect("the image's row");
    assert!(line.ends_with("| 15 / 0 / 0 |"), "{line}");
    assert!(tables.contains("| push constants | "), "{tables}");
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);
}

#[test]
fn a_killed_process_leaves_a_valid_profile() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("profile-killed");
    let report = dir.join("revz-profile.json");
    std::fs::remove_file(&report).ok();
    let mut command = clean_command(&harness.tester);
    command
        .arg("stress-threads")
        .args(harness.tester_args("d32", &dir))
        .args(["--threads", "2", "--frames", "100000"])
        .env("REVZ_MODE", "infinite")
        .env("REVZ_REPORT", &report)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null());
    harness.with_layer(&mut command);
    let mut child = command.spawn().expect("start revz-tester");
    // The first submission writes it; a rewrite follows every 2 s.
    let started = Instant::now();
    while !report.exists() && started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(2500));
    child.kill().expect("kill");
    child.wait().ok();
    assert!(report.exists(), "no profile after {:?}", started.elapsed());
    let profile: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap())
        .expect("the last profile written is whole JSON");
    assert!(
        profile["totals"]["frames"].as_u64().unwrap() >= 1,
        "{profile}"
    );
    let draws = &profile["totals"]["draws"];
    let total: u64 = ["native", "flip", "precise"]
        .iter()
        .map(|path| draws[path].as_u64().unwrap())
        .sum();
    assert!(total >= 1, "{profile}");
}

#[test]
fn warnings_are_kept_once_with_a_count_whatever_the_log_level() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("profile-warnings");
    let report = dir.join("revz-profile.json");
    std::fs::remove_file(&report).ok();
    let mut command = harness.tester("d32", &dir);
    command
        .args(["--scene", "overlap"])
        .env("REVZ_MODE", "infinite")
        .env("REVZ_FAR_CLIP", "bogus")
        .env("REVZ_REPORT", &report);
    harness.with_layer(&mut command);
    let render = harness.render(command, &dir);
    assert!(
        !render.stderr().contains("bogus"),
        "the log is off: {}",
        render.stderr()
    );
    let profile: Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("the profile")).unwrap();
    let warnings = profile["warnings"].as_array().expect("warnings");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0]["message"]
            .as_str()
            .unwrap()
            .starts_with("REVZ_FAR_CLIP: 'bogus' is not a valid far_clip"),
        "{warnings:?}"
    );
    assert_eq!(warnings[0]["count"], 1);
}
