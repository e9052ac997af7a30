//! OpenGL through Zink (issue #16): `revz-tester gl-render --zink` draws `sloped-plane` with a
//! small OpenGL program on Zink over lavapipe, without the layer, and the render must show the
//! scene: only its objects' colors and the clear color, every object over most of the pixels
//! the ground truth gives it, standard depth (nearer is smaller), and the
//! accuracy measurement's wrong-pixel fraction small. Where EGL or Zink cannot be initialised
//! (no libEGL, no Zink driver) the test says so and passes without checking anything.

use std::collections::HashMap;

use revz_tests::Harness;

/// The clear color `revz-tester` renders into (25/255 grey).
const CLEAR: [u8; 4] = [25, 25, 25, 255];
/// The ground truth's background in `expected.png`.
const EXPECTED_BACKGROUND: [u8; 4] = [0, 0, 0, 255];

/// Pixels per color.
fn histogram(image: &image::RgbaImage) -> HashMap<[u8; 4], usize> {
    let mut counts = HashMap::new();
    for pixel in image.pixels() {
        *counts.entry(pixel.0).or_insert(0) += 1;
    }
    counts
}

#[test]
fn sloped_plane_renders_through_zink_on_lavapipe() {
    let harness = Harness::locate();
    let out = harness.scratch_dir("zink-sloped-plane");
    let output = revz_tests::clean_command(&harness.tester)
        .args(["gl-render", "--zink", "--scene", "sloped-plane", "--out"])
        .arg(&out)
        .output()
        .expect("start revz-tester gl-render");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    );
    let context = format!("--- stdout\n{stdout}\n--- stderr\n{stderr}");
    if !output.status.success() && stderr.contains("cannot create an OpenGL context") {
        eprintln!(
            "SKIPPED sloped_plane_renders_through_zink_on_lavapipe: EGL or Zink cannot be \
             initialised here (needs libegl1, libegl-mesa0, libgl1-mesa-dri and \
             mesa-vulkan-drivers):\n{context}"
        );
        return;
    }
    assert!(output.status.success(), "gl-render failed\n{context}");
    assert!(
        stdout.contains("GL renderer: zink (llvmpipe"),
        "not Zink on lavapipe\n{context}"
    );

    let color = image::open(out.join("color.png"))
        .expect("color.png")
        .to_rgba8();
    let expected = image::open(out.join("expected.png"))
        .expect("expected.png")
        .to_rgba8();
    assert_eq!(color.dimensions(), expected.dimensions());
    let rendered = histogram(&color);
    let objects: HashMap<[u8; 4], usize> = histogram(&expected)
        .into_iter()
        .filter(|(c, _)| *c != EXPECTED_BACKGROUND)
        .collect();
    assert_eq!(
        objects.len(),
        2,
        "sloped-plane has two objects: {objects:?}"
    );
    for (c, n) in &rendered {
        assert!(
            *c == CLEAR || objects.contains_key(c),
            "{n} pixels of {c:?}, a color of no object of the scene\n{context}"
        );
    }
    for (c, n) in &objects {
        let shown = rendered.get(c).copied().unwrap_or(0);
        assert!(
            shown * 2 > *n,
            "object color {c:?} covers {shown} pixels, the ground truth {n}\n{context}"
        );
    }

    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("measurement.json")).expect("measurement.json"),
    )
    .expect("measurement.json parses");
    let m = &json["measurement"];
    assert!(m["checked_pixels"].as_u64().unwrap() > 1000, "{m}");
    // Standard depth with separate float32 matrices: a few percent of the red square loses
    // to the green plane (4 % on Mesa 22.3), never most of it.
    assert!(m["wrong_pixel_fraction"].as_f64().unwrap() < 0.1, "{m}");
    assert_eq!(m["depth_reversed"], false, "{m}");
}

/// Runs a `gl-render` command: its stderr, or `None` where EGL or Zink cannot be initialised
/// here (said on stderr); panics with its output where it failed otherwise.
fn run_gl_render(mut command: std::process::Command, name: &str) -> Option<String> {
    let output = command.output().expect("start revz-tester gl-render");
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    if !output.status.success() && stderr.contains("cannot create an OpenGL context") {
        eprintln!("SKIPPED {name}: EGL or Zink cannot be initialised here:\n{stderr}");
        return None;
    }
    assert!(
        output.status.success(),
        "gl-render {name} failed:\n{stderr}"
    );
    Some(stderr)
}

/// `gl-render --zink` of `scene`, through revz in `mode` (with `reverse_observable = all`: Zink
/// creates every depth image SAMPLED and TRANSFER_SRC, which the default policy keeps native),
/// or without it: the measurement, or `None` where Zink cannot be initialised.
fn zink_render(harness: &Harness, scene: &str, mode: Option<&str>) -> Option<serde_json::Value> {
    let name = format!("zink-{scene}-{}", mode.unwrap_or("none"));
    let out = harness.scratch_dir(&name);
    let mut command = revz_tests::clean_command(&harness.tester);
    command
        .args(["gl-render", "--zink", "--scene", scene, "--out"])
        .arg(&out);
    if let Some(mode) = mode {
        command
            .args(["--revz", mode])
            .env("REVZ_REVERSE_OBSERVABLE", "all");
    }
    let stderr = run_gl_render(command, &name)?;
    if mode.is_some() {
        assert!(
            stderr.contains("its vertex stage derives the range from the matrix it loads"),
            "{name}: Zink's pipeline did not take the precise path:\n{stderr}"
        );
    }
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("measurement.json")).expect("measurement.json"),
    )
    .expect("measurement.json parses");
    Some(json["measurement"].clone())
}

#[test]
fn zink_gets_the_precise_gain_through_revz() {
    // The OpenGL program's uniforms reach revz in a uniform buffer of uints, its products
    // written out column by column, its [-1, 1] clip depth set dynamically: the deriving
    // stage fits the projection's columns and converts the line, and revz sets [0, 1].
    let harness = Harness::locate();
    let Some(native) = zink_render(&harness, "sloped-plane", None) else {
        return;
    };
    let wrong = |m: &serde_json::Value| m["wrong_pixels"].as_u64().unwrap();
    assert!(
        wrong(&native) > 0,
        "standard depth loses some of the red square: {native}"
    );
    for mode in ["complementary", "infinite"] {
        let m = zink_render(&harness, "sloped-plane", Some(mode)).expect("Zink ran above");
        assert_eq!(m["depth_reversed"], true, "{m}");
        assert_eq!(
            wrong(&m),
            0,
            "sloped-plane through Zink and revz {mode}: {m}"
        );
    }
    // plane-stack: the minimum separation at every distance near float32's floor (the
    // precision model's 2.0e-7 for reversed float depth; measured 1.8e-7 to 5.6e-7 through
    // Zink, where Mesa multiplies P * (V * (M * v)) in float32), against 5.6e-7 to 3.2e-2
    // without revz.
    let native = zink_render(&harness, "plane-stack", None).expect("Zink ran above");
    let m = zink_render(&harness, "plane-stack", Some("infinite")).expect("Zink ran above");
    let separations = |m: &serde_json::Value| -> Vec<(f64, f64)> {
        m["min_rel_separation"]
            .as_array()
            .expect("plane-stack's separations")
            .iter()
            .map(|c| {
                (
                    c["distance_over_near"].as_f64().unwrap(),
                    c["min_rel_separation"].as_f64().unwrap_or(f64::INFINITY),
                )
            })
            .collect()
    };
    let (with, without) = (separations(&m), separations(&native));
    assert_eq!(with.len(), 6, "{m}");
    for ((distance, reversed), (_, standard)) in with.iter().zip(&without) {
        assert!(
            *reversed <= 4.0 * 2.0e-7,
            "plane-stack at {distance} n through Zink and revz: {reversed:e} (without revz \
             {standard:e})"
        );
    }
    assert!(without.last().unwrap().1 > 100.0 * with.last().unwrap().1);
}

/// `gl-render --zink --post PASS` of `overlap` (the depth attachment a texture a second pass
/// samples), without revz, or through it in `mode` with `reverse_observable` `observable`:
/// the post pass's color and the layer's log, or `None` where Zink cannot be initialised.
fn zink_post(
    harness: &Harness,
    pass: &str,
    mode: Option<(&str, &str)>,
) -> Option<(image::RgbaImage, String)> {
    let name = match mode {
        Some((mode, observable)) => format!("zink-post-{pass}-{mode}-{observable}"),
        None => format!("zink-post-{pass}-none"),
    };
    let out = harness.scratch_dir(&name);
    let mut command = revz_tests::clean_command(&harness.tester);
    command
        .args([
            "gl-render",
            "--zink",
            "--scene",
            "overlap",
            "--post",
            pass,
            "--out",
        ])
        .arg(&out);
    if let Some((mode, observable)) = mode {
        command
            .args(["--revz", mode])
            .env("REVZ_REVERSE_OBSERVABLE", observable)
            .env("REVZ_LOG", "info");
    }
    let stderr = run_gl_render(command, &name)?;
    let post = image::open(out.join("post.png"))
        .expect("post.png")
        .to_rgba8();
    Some((post, stderr))
}

/// Pixels whose channels differ by more than 2 levels.
fn far_apart(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    a.pixels()
        .zip(b.pixels())
        .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 2))
        .count()
}

/// Issue #39 through Zink: an OpenGL program that samples its depth texture after drawing
/// (texel fetches spread over the colors, and a shadow sampler comparing against 0.98) sees
/// the values it would see without revz: under the default policy the depth image is reversed
/// and the post pass reads its read twin (measured: 1 of 65,536 pixels off by more than 2
/// levels in `complementary` and `flip`, a depth on a band's edge). In `infinite`, where every
/// projection is in a buffer and revz's CPU knows no n/f, the deriving stage stores
/// complementary depth, which the refresh maps back exactly (before, it stored n/w, read back
/// as (1 - n/f) D: 56,184 fetch and 1,231 compare pixels off). With
/// `reverse_observable = all` the shaders read the reversed values, and most pixels change.
#[test]
fn zink_shaders_sample_standard_depth_through_the_read_twin() {
    let harness = Harness::locate();
    for pass in ["fetch", "compare"] {
        let Some((native, _)) = zink_post(&harness, pass, None) else {
            return;
        };
        for mode in ["flip", "complementary", "infinite"] {
            let (post, log) = zink_post(&harness, pass, Some((mode, "copies"))).expect("Zink ran");
            assert!(
                log.contains("reversed, shaders read its twin"),
                "{mode}: {log}"
            );
            let apart = far_apart(&native, &post);
            eprintln!("zink post {pass} {mode}: {apart} of 65,536 pixels apart");
            assert!(apart <= 16, "{pass} {mode}: {apart} pixels differ\n{log}");
        }
        let (raw, _) = zink_post(&harness, pass, Some(("complementary", "all"))).expect("Zink ran");
        let apart = far_apart(&native, &raw);
        assert!(
            apart > 65_536 / 20,
            "{pass}: reading the reversed values changed only {apart} pixels"
        );
    }
}

/// `gl-render --zink` of `overlap`'s depth as `glReadPixels(GL_DEPTH_COMPONENT, GL_FLOAT)`
/// returns it (`depth.f32`), without revz or through it in `mode` under the default policy
/// (`reverse_observable = copies`, `copy_values = standard`, which `gl-render` otherwise sets
/// to `stored` for its measurements), or `None` where Zink cannot be initialised.
fn zink_read_depth(harness: &Harness, mode: Option<&str>) -> Option<(Vec<f32>, String)> {
    let name = format!("zink-read-depth-{}", mode.unwrap_or("none"));
    let out = harness.scratch_dir(&name);
    let mut command = revz_tests::clean_command(&harness.tester);
    command
        .args(["gl-render", "--zink", "--scene", "overlap", "--out"])
        .arg(&out);
    if let Some(mode) = mode {
        command
            .args(["--revz", mode])
            .env("REVZ_REVERSE_OBSERVABLE", "copies")
            .env("REVZ_COPY_VALUES", "standard")
            .env("REVZ_LOG", "info");
    }
    let stderr = run_gl_render(command, &name)?;
    let bytes = std::fs::read(out.join("depth.f32")).expect("depth.f32");
    let depth = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    Some((depth, stderr))
}

/// Issue #39 through Zink: `glReadPixels` of depth reads the values it reads without revz,
/// though the depth image is reversed (Zink copies it to a buffer, and revz converts the
/// copy). Within 2 float32 ulps below 1 (2.4e-7; measured 1.2e-7, one rounding of the
/// conversion) in every mode: in `infinite` too, where with every projection in a uniform
/// buffer the deriving stage stores complementary depth, exact under the map the copy uses
/// (storing n/w, it read back (1 - n/f) D).
#[test]
fn zink_reads_depth_back_as_it_does_without_revz() {
    let harness = Harness::locate();
    let Some((native, _)) = zink_read_depth(&harness, None) else {
        return;
    };
    for mode in ["flip", "complementary", "infinite"] {
        let (depth, log) = zink_read_depth(&harness, Some(mode)).expect("Zink ran");
        assert!(
            log.contains("reversed, shaders read its twin"),
            "{mode}: the depth image is not reversed\n{log}"
        );
        assert_eq!(depth.len(), native.len());
        let worst = native
            .iter()
            .zip(&depth)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        eprintln!("zink glReadPixels depth {mode}: worst difference {worst:e}");
        assert!(
            worst <= 2.4e-7,
            "{mode}: depth read back {worst:e} from the run without revz\n{log}"
        );
    }
}
