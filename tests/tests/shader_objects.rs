//! End-to-end tests of shader objects (`VK_EXT_shader_object`, issue #41): the tester's
//! `--delivery shader-objects` binds the flat program as unlinked vertex and fragment shader
//! objects and sets every state of the pipeline it replaces dynamically, as engines built on
//! shader objects do. revz gives such a vertex shader a variant with its carrier baked in
//! (`layer/src/hooks/shader_object.rs`) and binds it for precise-path draws.
//!
//! Mesa 22.3's lavapipe has no shader objects: these render on the newer lavapipe
//! `cargo xtask setup` extracts beside it on Debian 12 (Mesa 25.0 from bookworm-backports,
//! [`Harness::newer_lavapipe`]), or on the system's own where that is new enough. The
//! installed validation layer (1.3.239) predates the extension: it rejects the extension's
//! feature structure and hides its dynamic state commands, so the tester renders these
//! without it and says so in `render.json` (`validation_skipped`); the tests check that it
//! says so, and where a newer layer runs, that it counts no message.
//!
//! - `without_the_layer_shader_objects_render_the_pipelines_image`: the scenes' images (color
//!   and depth, bit for bit) are those of the flat program's pipelines: the tester's shader
//!   objects set the state the pipelines bake.
//! - `shader_objects_take_the_precise_path_in_every_precise_mode_and_format`: the accuracy
//!   report of the hard cases in every mode and format. In `complementary` and `infinite`
//!   (D16/D24 promoted to float32) `sloped-plane` and `mars-patch` have no wrong pixel (17.5%
//!   and 3.1% without revz), which the flip path cannot give; `plane-stack` stays within the
//!   float32 floor (under 1%); `deep-range`, whose per-object matrices the baked route fits
//!   one object at a time (docs/precise.md, "No room for the carrier"), is still better than
//!   without revz. `flip` and no layer read what the pipelines read.
//! - `overlap_keeps_the_native_colors_with_shader_objects_in_every_mode`: the colors of the
//!   render without revz, in `flip`, `complementary` and `infinite`.

use std::path::Path;
use std::process::Command;

use revz_tests::{clean_command, differing_pixels, unexplained_color_differences, Harness, Render};

/// What the tester says where it left validation out ([`Harness`] renders ask for it).
const SKIPPED: &str = "predates VK_EXT_shader_object";

/// The accuracy scenes the shader-object delivery takes.
const SCENES: [&str; 5] = [
    "sloped-plane",
    "mars-patch",
    "plane-stack",
    "deep-range",
    "far-objects",
];

fn render(harness: &Harness, scene: &str, delivery: &str, mode: Option<&str>) -> Render {
    let label = mode.unwrap_or("native");
    let dir = harness.scratch_dir(&format!("shader-objects-{scene}-{delivery}-{label}"));
    let mut command = harness.tester("d32", &dir);
    command
        .args(["--scene", scene, "--delivery", delivery])
        .args(["--width", "160", "--height", "120"]);
    harness.on_newer_lavapipe(&mut command);
    if let Some(mode) = mode {
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", mode)
            .env("REVZ_LOG", "debug");
    }
    let render = harness.render(command, &dir);
    assert_validation_accounted(&render.json(), &format!("{scene} {delivery} {label}"));
    render
}

/// Validation ran and counted nothing, or the render says why it did not run.
fn assert_validation_accounted(json: &serde_json::Value, what: &str) {
    assert_eq!(json["validation_messages"], 0, "{what}: {json}");
    if json["delivery"] == "shader-objects" {
        if let Some(why) = json["validation_skipped"].as_str() {
            assert!(why.contains(SKIPPED), "{what}: {why}");
        }
    } else {
        assert!(json["validation_skipped"].is_null(), "{what}: {json}");
    }
}

#[test]
fn without_the_layer_shader_objects_render_the_pipelines_image() {
    let harness = Harness::locate();
    for scene in ["sloped-plane", "plane-stack", "overlap"] {
        let pipelines = render(&harness, scene, "push", None);
        let objects = render(&harness, scene, "shader-objects", None);
        assert_eq!(
            differing_pixels(&pipelines.color(), &objects.color()),
            0,
            "{scene}: colors"
        );
        let (a, b) = (pipelines.depth(), objects.depth());
        assert_eq!(a.len(), b.len());
        let differing = a
            .iter()
            .zip(&b)
            .filter(|(x, y)| x.to_bits() != y.to_bits())
            .count();
        assert_eq!(differing, 0, "{scene}: depth values");
    }
}

fn report(harness: &Harness, out: &Path) -> serde_json::Value {
    let mut command: Command = clean_command(&harness.tester);
    command
        .arg("report")
        .arg("--out")
        .arg(out)
        .args(["--device", "llvmpipe"])
        .arg("--layer-dir")
        .arg(&harness.explicit_manifest_dir)
        .args(["--scenes", &SCENES.join(",")])
        .args(["--modes", "none,flip,complementary,infinite"])
        .args(["--formats", "d16,x8-d24,d24-s8,d32,d32-s8"])
        .args(["--deliveries", "push,shader-objects"]);
    harness.on_newer_lavapipe(&mut command);
    let output = command.output().expect("start revz-tester report");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    assert_eq!(output.status.code(), Some(0), "{text}");
    serde_json::from_slice(&std::fs::read(out.join("report.json")).expect("report.json"))
        .expect("JSON")
}

#[test]
fn shader_objects_take_the_precise_path_in_every_precise_mode_and_format() {
    let harness = Harness::locate();
    let out = harness.scratch_dir("shader-objects-report");
    let report = report(&harness, &out);
    let rows = report["rows"].as_array().expect("rows");
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
    for scene in SCENES {
        for format in ["d16", "x8-d24", "d24-s8", "d32", "d32-s8"] {
            for mode in ["none", "flip", "complementary", "infinite"] {
                let r = find(scene, "shader-objects", mode, format);
                let what = format!("{scene} {mode} {format}");
                assert!(r["error"].is_null(), "{what}: {r}");
                assert!(r["checked_pixels"].as_u64().unwrap() > 3000, "{what}: {r}");
                if let Some(why) = r["validation_skipped"].as_str() {
                    assert!(why.contains(SKIPPED), "{what}: {why}");
                }
                let own = fraction(r);
                let pipelines = fraction(find(scene, "push", mode, format));
                let native = fraction(find(scene, "shader-objects", "none", format));
                eprintln!(
                    "{what}: {own:.3e} wrong (pipelines {pipelines:.3e}, no revz {native:.3e})"
                );
                match mode {
                    // The same depth path as the pipelines: the same image.
                    "none" | "flip" if own != pipelines => problems.push(format!(
                        "{what}: {own:.3e} wrong against the pipelines' {pipelines:.3e}"
                    )),
                    "complementary" | "infinite" => {
                        let bound = match scene {
                            "sloped-plane" | "mars-patch" => 0.0,
                            "plane-stack" => 0.01,
                            "far-objects" => 0.005,
                            // One fitted range per object (module docs).
                            _ => 0.9 * native,
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
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn overlap_keeps_the_native_colors_with_shader_objects_in_every_mode() {
    let harness = Harness::locate();
    let native = render(&harness, "overlap", "shader-objects", None);
    let truth = native.ground_truth();
    let mut problems = Vec::new();
    for mode in ["flip", "complementary", "infinite"] {
        let layered = render(&harness, "overlap", "shader-objects", Some(mode));
        let log = layered.stderr();
        if !log.contains("): reversed") {
            problems.push(format!(
                "{mode}: the depth attachment was not reversed: {log}"
            ));
        }
        if mode != "flip" && !log.contains("stores its depth for precise-path draws") {
            problems.push(format!("{mode}: no shader object variant: {log}"));
        }
        let (a, b) = (native.color(), layered.color());
        let unexplained = unexplained_color_differences(&a, &b, &truth);
        eprintln!(
            "overlap shader-objects {mode}: {} color pixels differ from the native render, {} \
             unexplained",
            differing_pixels(&a, &b),
            unexplained.len()
        );
        if !unexplained.is_empty() {
            problems.push(format!(
                "{mode}: {} pixels differ where the ground truth does not explain it: {}",
                unexplained.len(),
                unexplained
                    .iter()
                    .take(8)
                    .cloned()
                    .collect::<Vec<_>>()
                    .join("; ")
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
