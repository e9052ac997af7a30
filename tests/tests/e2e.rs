//! End-to-end: the tester on lavapipe, under the Khronos validation layer, with and without
//! revz. Every render must report zero validation messages (checked by `Harness::render`).

use std::process::Command;

use revz_tests::{differing_depths, differing_pixels, Harness, LAYER_NAME, MODES};

/// Renders `format` natively, then through the layer in every mode, and requires the layer's
/// renders to be bit-identical: every mode passes everything through in this build.
fn passthrough_is_bit_identical(format: &str) {
    let harness = Harness::locate();
    let native_dir = harness.scratch_dir(&format!("{format}-native"));
    let native = harness.render(harness.tester(format, &native_dir), &native_dir);
    assert_eq!(
        native.loaded_mode(),
        None,
        "the layer was loaded without being asked for"
    );
    let json = native.json();
    let covered = json["covered_pixels"].as_u64().unwrap();
    assert!(covered > 1000, "the scene barely covers the image: {json}");

    for mode in MODES {
        let dir = harness.scratch_dir(&format!("{format}-{mode}"));
        let mut command = harness.tester(format, &dir);
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", mode)
            .env("REVZ_LOG", "info");
        let layered = harness.render(command, &dir);
        assert_eq!(
            layered.loaded_mode().as_deref(),
            Some(mode),
            "the layer did not log its load line\n{}",
            layered.stderr()
        );
        let (color_a, color_b) = (native.color(), layered.color());
        assert_eq!(
            differing_pixels(&color_a, &color_b),
            0,
            "{format}, mode {mode}: color differs from the native render"
        );
        let (depth_a, depth_b) = (native.depth(), layered.depth());
        assert_eq!(
            differing_depths(&depth_a, &depth_b),
            0,
            "{format}, mode {mode}: depth differs from the native render"
        );
    }
}

#[test]
fn passthrough_d16() {
    passthrough_is_bit_identical("d16");
}

#[test]
fn passthrough_x8_d24() {
    passthrough_is_bit_identical("x8-d24");
}

#[test]
fn passthrough_d24_s8() {
    passthrough_is_bit_identical("d24-s8");
}

#[test]
fn passthrough_d32() {
    passthrough_is_bit_identical("d32");
}

#[test]
fn passthrough_d32_s8() {
    passthrough_is_bit_identical("d32-s8");
}

#[test]
fn unknown_mode_warns_naming_the_valid_modes_and_falls_back_to_off() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("unknown-mode");
    let mut command = harness.tester("d32", &dir);
    harness
        .with_layer(&mut command)
        .env("REVZ_MODE", "upside-down")
        .env("REVZ_LOG", "warn");
    let render = harness.render(command, &dir);
    let stderr = render.stderr();
    assert!(
        stderr.contains(
            "REVZ_MODE: 'upside-down' is not a valid mode \
             (expected one of: off, flip, complementary, infinite); using off"
        ),
        "{stderr}"
    );
    // Info is not enabled: the warning is the only line.
    assert_eq!(stderr.matches("[revz ").count(), 1, "{stderr}");

    let dir = harness.scratch_dir("unknown-mode-info");
    let mut command = harness.tester("d32", &dir);
    harness
        .with_layer(&mut command)
        .env("REVZ_MODE", "upside-down")
        .env("REVZ_LOG", "info");
    assert_eq!(
        harness.render(command, &dir).loaded_mode().as_deref(),
        Some("off")
    );
}

#[test]
fn the_layer_is_silent_by_default_and_logs_to_a_file_on_request() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("silent");
    let mut command = harness.tester("d32", &dir);
    harness.with_layer(&mut command).env("REVZ_MODE", "flip");
    let render = harness.render(command, &dir);
    assert!(!render.stderr().contains("[revz "), "{}", render.stderr());

    let dir = harness.scratch_dir("log-file");
    let log = dir.join("revz.log");
    let mut command = harness.tester("d32", &dir);
    harness
        .with_layer(&mut command)
        .env("REVZ_LOG", "info")
        .env("REVZ_LOG_FILE", &log);
    let render = harness.render(command, &dir);
    assert!(!render.stderr().contains("[revz "), "{}", render.stderr());
    let text = std::fs::read_to_string(&log).expect("the log file was written");
    assert!(
        text.contains(&format!("{LAYER_NAME}: mode complementary")),
        "{text}"
    );
}

#[test]
fn vulkaninfo_lists_the_layer_and_creates_the_lavapipe_device() {
    let harness = Harness::locate();
    let output = Command::new("vulkaninfo")
        .arg("--summary")
        .env("VK_ADD_LAYER_PATH", &harness.explicit_manifest_dir)
        .env("VK_INSTANCE_LAYERS", LAYER_NAME)
        .env("REVZ_LOG", "info")
        .env_remove("REVZ_MODE")
        .output()
        .expect("vulkaninfo is missing: apt-get install vulkan-tools");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains(LAYER_NAME), "{stdout}");
    assert!(stdout.contains("llvmpipe"), "{stdout}");
    assert!(
        stderr.contains("loaded as VK_LAYER_REVZ_reverse_z"),
        "{stderr}"
    );
    assert!(!stderr.contains("ERROR"), "{stderr}");
}

/// The implicit manifest, installed where the loader looks for a user's implicit layers:
/// off unless `ENABLE_REVZ=1`, and `DISABLE_REVZ=1` wins.
#[test]
fn the_implicit_layer_follows_enable_and_disable_variables() {
    let harness = Harness::locate();
    let data_home = harness.scratch_dir("implicit-data-home");
    let layer_dir = data_home.join("vulkan/implicit_layer.d");
    std::fs::create_dir_all(&layer_dir).unwrap();
    std::fs::copy(
        harness.implicit_manifest_dir.join("VkLayer_revz.json"),
        layer_dir.join("VkLayer_revz.json"),
    )
    .unwrap();

    type Case<'a> = (&'a str, &'a [(&'a str, &'a str)], bool);
    let cases: [Case; 3] = [
        ("implicit-default", &[], false),
        ("implicit-enabled", &[("ENABLE_REVZ", "1")], true),
        (
            "implicit-disabled",
            &[("ENABLE_REVZ", "1"), ("DISABLE_REVZ", "1")],
            false,
        ),
    ];
    for (name, env, loaded) in cases {
        let dir = harness.scratch_dir(name);
        let mut command = harness.tester("d32", &dir);
        command
            .env("XDG_DATA_HOME", &data_home)
            .env("REVZ_LOG", "info")
            .envs(env.iter().copied());
        let render = harness.render(command, &dir);
        assert_eq!(
            render.loaded_mode().is_some(),
            loaded,
            "{name}: {}",
            render.stderr()
        );
    }
}
