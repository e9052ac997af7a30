//! revz's depth profile (issue #19, `layer/src/profile.rs`): for tester scenes in every mode,
//! the profile written with `REVZ_REPORT` says exactly what the scene does (the draws per path,
//! the reversed and native depth images with their reasons, the cameras with the scene's
//! range), and a killed process leaves a valid profile.

use std::time::{Duration, Instant};

use revz_tests::{clean_command, Harness};
use serde_json::Value;

/// Renders `scene` through revz in `mode` (no depth readback, so the depth image may be
/// reversed) with its profile written to `report`: the render's `render.json` and the profile.
fn profiled(harness: &Harness, scene: &str, delivery: &str, mode: &str) -> (Value, Value) {
    let dir = harness.scratch_dir(&format!("profile-{scene}-{delivery}-{mode}"));
    let report = dir.join("revz-profile.json");
    std::fs::remove_file(&report).ok();
    let mut command = harness.tester("d32", &dir);
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
    harness.with_layer(&mut command);
    let render = harness.render(command, &dir);
    // The tester prints the profile's summary at its end.
    assert!(
        render.stdout().contains("revz: precise "),
        "{}",
        render.stdout()
    );
    let profile: Value =
        serde_json::from_str(&std::fs::read_to_string(&report).expect("the profile")).unwrap();
    (render.json(), profile)
}

fn draws(profile: &Value) -> (u64, u64, u64) {
    let d = &profile["totals"]["draws"];
    let n = |k: &str| d[k].as_u64().unwrap();
    (n("precise"), n("flip"), n("native"))
}

#[test]
fn the_profile_says_what_each_scene_does() {
    let harness = Harness::locate();
    // (scene, delivery, draws into the reversed attachment, draws into a native one, native
    // images and why)
    let scenes = [
        ("overlap", "push", 5, 0, None),
        ("secondary", "push", 5, 0, None),
        ("sloped-plane", "ubo", 2, 0, None),
        ("far-objects", "ssbo", 18, 0, None),
        ("shadow-map", "push", 5, 5, Some("SAMPLED")),
    ];
    for (scene, delivery, reversed_draws, native_draws, native_image) in scenes {
        for mode in ["flip", "complementary", "infinite"] {
            let what = format!("{scene} ({delivery}) in {mode}");
            let (render, profile) = profiled(&harness, scene, delivery, mode);
            let objects = render["ground_truth"]["objects"]
                .as_array()
                .map_or(0, Vec::len);
            assert_eq!(
                objects as u64, reversed_draws,
                "{what}: the scene's objects"
            );
            let (precise, flip, native) = draws(&profile);
            if mode == "flip" {
                assert_eq!(
                    (precise, flip, native),
                    (0, reversed_draws, native_draws),
                    "{what}"
                );
            } else {
                assert_eq!(
                    (precise, flip, native),
                    (reversed_draws, 0, native_draws),
                    "{what}"
                );
            }
            assert_eq!(profile["totals"]["frames"], 1, "{what}");
            let images = profile["images"].as_array().expect("images");
            let reversed: Vec<&Value> =
                images.iter().filter(|i| i["depth"] == "reversed").collect();
            assert_eq!(reversed.len(), 1, "{what}: {images:?}");
            assert_eq!(reversed[0]["format"], "D32_SFLOAT", "{what}");
            let native: Vec<&Value> = images.iter().filter(|i| i["depth"] == "native").collect();
            match native_image {
                None => assert!(native.is_empty(), "{what}: {native:?}"),
                Some(reason) => {
                    assert_eq!(native.len(), 1, "{what}: {native:?}");
                    let why = native[0]["reason"].as_str().unwrap();
                    assert!(why.contains(reason), "{what}: {why}");
                }
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
            let pipelines = profile["pipelines"].as_array().expect("pipelines");
            assert!(!pipelines.is_empty(), "{what}");
            let cameras = profile["cameras"].as_array().expect("cameras");
            let near = render["ground_truth"]["near"].as_f64().unwrap();
            match (mode, delivery) {
                ("flip", _) => {
                    assert!(pipelines.iter().all(|p| p["path"] == "flip"), "{what}");
                    assert!(cameras.is_empty(), "{what}: {cameras:?}");
                }
                (_, "push") => {
                    assert!(pipelines.iter().all(|p| p["path"] == "precise"), "{what}");
                    // The camera's range is the scene's (float32 matrices: within 1e-5).
                    assert_eq!(cameras.len(), 1, "{what}: {cameras:?}");
                    let found = cameras[0]["near"].as_f64().unwrap();
                    assert!(
                        (found / near - 1.0).abs() < 1e-5,
                        "{what}: {found} vs {near}"
                    );
                }
                _ => {
                    // The stage fits its range: the CPU learns no camera.
                    assert!(
                        pipelines.iter().all(|p| p["path"] == "precise"
                            && p["projection"].as_str().unwrap().contains("fitted")),
                        "{what}: {pipelines:?}"
                    );
                    assert!(cameras.is_empty(), "{what}: {cameras:?}");
                }
            }
            let summary = profile["summary"].as_str().unwrap();
            let expected = if mode == "flip" {
                "precise 0%"
            } else {
                "precise "
            };
            assert!(summary.starts_with(expected), "{what}: {summary}");
        }
    }
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
