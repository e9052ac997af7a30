//! OpenGL through Zink (issue #16): `revz-tester gl-render --zink` draws `sloped-plane` with a
//! small OpenGL program on Zink over lavapipe, without the layer, and the render must show the
//! scene: only its objects' colors and the clear color, every object over most of the pixels
//! the ground truth gives it, standard depth (nearer is smaller), and the
//! accuracy measurement's wrong-pixel fraction small. Where EGL or Zink cannot be initialised
//! (no libEGL, no Zink driver) the test says so and passes without checking anything.

use std::collections::HashMap;

use revz_tests::{Harness, NewerZink};

/// The Zinks the tests render through: the system's (Mesa 22.3 on Debian 12), and Mesa 25.0's
/// on its lavapipe where `cargo xtask setup` extracted them beside the system's
/// ([`Harness::newer_zink`]): a newer Zink drives Vulkan otherwise (its shaders, its
/// pipelines, its copies), as the applications' users run it. Mesa 25.0's also with the scene
/// drawn by separable programs (`gl-render --separable`) and `ZINK_DEBUG=optimal_keys`, with
/// which Zink compiles each stage on its own as a shader object (`VK_EXT_shader_object`,
/// which Mesa 25.0's lavapipe has) and draws with them: the vertex shader object takes revz's
/// pushed route, the fitted [-1, 1] line converted (with the layer of session 31, whose shader
/// objects had the carrier baked in and took the flip path for [-1, 1] clip depth,
/// `sloped-plane` read 10.2% wrong in `infinite`, against 0 now).
#[derive(Clone, Debug)]
enum Zink {
    System,
    Newer(NewerZink),
    NewerShaderObjects(NewerZink),
}

impl Zink {
    fn all(harness: &Harness) -> Vec<Zink> {
        let mut all = vec![Zink::System];
        match harness.newer_zink() {
            Some(newer) => {
                all.push(Zink::Newer(newer.clone()));
                all.push(Zink::NewerShaderObjects(newer));
            }
            None => {
                eprintln!("no newer Zink here (cargo xtask setup, Debian 12): the system's alone")
            }
        }
        all
    }

    /// Its part of a scratch directory's name.
    fn label(&self) -> &'static str {
        match self {
            Zink::System => "",
            Zink::Newer(_) => "-mesa25",
            Zink::NewerShaderObjects(_) => "-mesa25-shader-objects",
        }
    }

    /// `revz-tester gl-render --zink` through this Zink, in a clean environment.
    fn command(&self, harness: &Harness) -> std::process::Command {
        let mut command = revz_tests::clean_command(&harness.tester);
        command.args(["gl-render", "--zink"]);
        match self {
            Zink::System => {}
            Zink::Newer(newer) => {
                newer.apply(&mut command);
            }
            Zink::NewerShaderObjects(newer) => {
                newer
                    .apply(&mut command)
                    .arg("--separable")
                    .env("ZINK_DEBUG", "optimal_keys");
            }
        }
        command
    }

    /// What the layer logs (`debug`) where the scene's last pre-rasterization stage takes the
    /// precise path: Zink's pipeline's vertex stage fitting the matrix it loads, or its vertex
    /// shader object's variant reading the pushed carrier.
    fn precise_line(&self) -> &'static str {
        match self {
            Zink::System | Zink::Newer(_) => {
                "its vertex stage derives the range from the matrix it loads"
            }
            Zink::NewerShaderObjects(_) => {
                "its code storing Position through revz's pushed carrier"
            }
        }
    }
}

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
    for zink in Zink::all(&harness) {
        sloped_plane_renders(&harness, &zink);
    }
}

fn sloped_plane_renders(harness: &Harness, zink: &Zink) {
    let out = harness.scratch_dir(&format!("zink-sloped-plane{}", zink.label()));
    let output = zink
        .command(harness)
        .args(["--scene", "sloped-plane", "--out"])
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
    // "zink (llvmpipe ..." (Mesa 22.3), "zink Vulkan 1.4(llvmpipe ..." (25.0).
    assert!(
        stdout.contains("GL renderer: zink") && stdout.contains("(llvmpipe"),
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
fn zink_render(
    harness: &Harness,
    zink: &Zink,
    scene: &str,
    mode: Option<&str>,
) -> Option<serde_json::Value> {
    zink_render_with(harness, zink, scene, mode, &[])
}

/// [`zink_render`] with more `gl-render` arguments (`args`, which also name its scratch
/// directory).
fn zink_render_with(
    harness: &Harness,
    zink: &Zink,
    scene: &str,
    mode: Option<&str>,
    args: &[&str],
) -> Option<serde_json::Value> {
    let name = format!(
        "zink-{scene}-{}{}{}",
        mode.unwrap_or("none"),
        zink.label(),
        args.concat()
    );
    let out = harness.scratch_dir(&name);
    let mut command = zink.command(harness);
    command.args(args);
    command.args(["--scene", scene, "--out"]).arg(&out);
    if let Some(mode) = mode {
        command
            .args(["--revz", mode])
            .env("REVZ_REVERSE_OBSERVABLE", "all");
    }
    let stderr = run_gl_render(command, &name)?;
    if mode.is_some() {
        assert!(
            stderr.contains(zink.precise_line()),
            "{name}: Zink's stage did not take the precise path:\n{stderr}"
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
    let harness = Harness::locate();
    for zink in Zink::all(&harness) {
        precise_gain(&harness, &zink);
    }
}

fn precise_gain(harness: &Harness, zink: &Zink) {
    // The OpenGL program's uniforms reach revz in a uniform buffer of uints, its products
    // written out column by column, its [-1, 1] clip depth set dynamically: the deriving
    // stage fits the projection's columns and converts the line, and revz sets [0, 1].
    let Some(native) = zink_render(harness, zink, "sloped-plane", None) else {
        return;
    };
    let wrong = |m: &serde_json::Value| m["wrong_pixels"].as_u64().unwrap();
    assert!(
        wrong(&native) > 0,
        "standard depth loses some of the red square: {native}"
    );
    for mode in ["complementary", "infinite"] {
        let m = zink_render(harness, zink, "sloped-plane", Some(mode)).expect("Zink ran above");
        assert_eq!(m["depth_reversed"], true, "{m}");
        assert_eq!(
            wrong(&m),
            0,
            "sloped-plane through Zink{} and revz {mode}: {m}",
            zink.label()
        );
    }
    // plane-stack: the minimum separation at every distance near float32's floor (the
    // precision model's 2.0e-7 for reversed float depth; measured 1.8e-7 to 5.6e-7 through
    // Zink, where Mesa multiplies P * (V * (M * v)) in float32), against 5.6e-7 to 3.2e-2
    // without revz.
    let native = zink_render(harness, zink, "plane-stack", None).expect("Zink ran above");
    let m = zink_render(harness, zink, "plane-stack", Some("infinite")).expect("Zink ran above");
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
            "plane-stack at {distance} n through Zink{} and revz: {reversed:e} (without revz \
             {standard:e})",
            zink.label()
        );
    }
    assert!(without.last().unwrap().1 > 100.0 * with.last().unwrap().1);
}

#[test]
fn zink_gets_the_precise_gain_for_a_position_built_from_computed_components() {
    // `vec4(position.x, position.y + u_zero * position.x, position.z, 1.0)` (glmark2's
    // `conditionals`, `function` and `loop` build theirs so): Mesa's NIR multiplies the
    // matrix's column by a splat of the computed y, no component of a vector; and an offset
    // of w 0 added before the projection (glmark2's `terrain`). revz fitted neither before
    // session 33 (the flip path: 4.0% of sloped-plane wrong in `infinite`, as without revz).
    let harness = Harness::locate();
    for zink in Zink::all(&harness) {
        // A separable program has no such form here (`gl-render` refuses the two together).
        if matches!(zink, Zink::NewerShaderObjects(_)) {
            continue;
        }
        let computed = ["--computed-position"];
        let Some(native) = zink_render_with(&harness, &zink, "sloped-plane", None, &computed)
        else {
            return;
        };
        let wrong = |m: &serde_json::Value| m["wrong_pixels"].as_u64().unwrap();
        assert!(wrong(&native) > 0, "standard depth loses some: {native}");
        for mode in ["complementary", "infinite"] {
            let m = zink_render_with(&harness, &zink, "sloped-plane", Some(mode), &computed)
                .expect("Zink ran above");
            assert_eq!(m["depth_reversed"], true, "{m}");
            assert_eq!(
                wrong(&m),
                0,
                "sloped-plane with a computed position through Zink{} and revz {mode}: {m}",
                zink.label()
            );
        }
    }
}

/// `gl-render --zink --post PASS` of `overlap` (the depth attachment a texture a second pass
/// samples), without revz, or through it in `mode` with `reverse_observable` `observable`:
/// the post pass's color and the layer's log, or `None` where Zink cannot be initialised.
fn zink_post(
    harness: &Harness,
    zink: &Zink,
    pass: &str,
    mode: Option<(&str, &str)>,
) -> Option<(image::RgbaImage, String)> {
    let name = match mode {
        Some((mode, observable)) => format!("zink-post-{pass}-{mode}-{observable}"),
        None => format!("zink-post-{pass}-none"),
    } + zink.label();
    let out = harness.scratch_dir(&name);
    let mut command = zink.command(harness);
    command
        .args(["--scene", "overlap", "--post", pass, "--out"])
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
    for zink in Zink::all(&harness) {
        sample_standard_depth(&harness, &zink);
    }
}

fn sample_standard_depth(harness: &Harness, zink: &Zink) {
    let label = zink.label();
    for pass in ["fetch", "compare"] {
        let Some((native, _)) = zink_post(harness, zink, pass, None) else {
            return;
        };
        for mode in ["flip", "complementary", "infinite"] {
            let (post, log) =
                zink_post(harness, zink, pass, Some((mode, "copies"))).expect("Zink ran");
            assert!(
                log.contains("reversed, shaders read its twin"),
                "{mode}: {log}"
            );
            let apart = far_apart(&native, &post);
            eprintln!("zink{label} post {pass} {mode}: {apart} of 65,536 pixels apart");
            assert!(
                apart <= 16,
                "{pass} {mode}{label}: {apart} pixels differ\n{log}"
            );
        }
        let (raw, _) =
            zink_post(harness, zink, pass, Some(("complementary", "all"))).expect("Zink ran");
        let apart = far_apart(&native, &raw);
        assert!(
            apart > 65_536 / 20,
            "{pass}{label}: reading the reversed values changed only {apart} pixels"
        );
    }
}

/// An OpenGL program that runs a compute shader (a storage buffer written, as a culling or
/// particle pass would) before it draws and again before it samples its depth texture, in one
/// frame (`gl-render --compute-first --post fetch|compare`): Zink binds its compute
/// descriptors before the barrier at which revz refreshes the read twin, in one command
/// buffer. On Mesa 25.0's Zink those are descriptor buffers (`vkCmdSetDescriptorBufferOffsetsEXT`
/// on lavapipe 25.0, as on every driver with `VK_EXT_descriptor_buffer`), which revz binds
/// again after its conversion's dispatch since session 36; before, it refused the refresh and
/// the post pass read a twin never written: every pixel of `fetch` and 36,231 of `compare`
/// apart, in every mode (session 35's layer, measured). Now within
/// `zink_shaders_sample_standard_depth_through_the_read_twin`'s bound in every mode, on both
/// Zinks, and the compute pass's words are what its dispatches wrote (`gl-render` checks them).
#[test]
fn zink_shaders_sample_depth_after_a_compute_pass_as_without_revz() {
    let harness = Harness::locate();
    for zink in Zink::all(&harness) {
        let label = zink.label();
        for pass in ["fetch", "compare"] {
            let run = |mode: Option<&str>| {
                let name = format!("zink-compute-{pass}-{}{label}", mode.unwrap_or("none"));
                let out = harness.scratch_dir(&name);
                let mut command = zink.command(&harness);
                command
                    .args([
                        "--scene",
                        "overlap",
                        "--compute-first",
                        "--post",
                        pass,
                        "--out",
                    ])
                    .arg(&out);
                if let Some(mode) = mode {
                    command
                        .args(["--revz", mode])
                        .env("REVZ_REVERSE_OBSERVABLE", "copies")
                        .env("REVZ_LOG", "info");
                }
                let log = run_gl_render(command, &name)?;
                let post = image::open(out.join("post.png"))
                    .expect("post.png")
                    .to_rgba8();
                Some((post, log))
            };
            let Some((native, _)) = run(None) else {
                break;
            };
            for mode in ["flip", "complementary", "infinite"] {
                let (post, log) = run(Some(mode)).expect("Zink ran");
                assert!(
                    log.contains("reversed, shaders read its twin"),
                    "{mode}{label}: {log}"
                );
                assert!(!log.contains("not refreshed"), "{mode}{label}: {log}");
                let apart = far_apart(&native, &post);
                eprintln!(
                    "zink{label} compute, post {pass} {mode}: {apart} of 65,536 pixels apart"
                );
                assert!(
                    apart <= 16,
                    "{pass} {mode}{label}: {apart} pixels differ\n{log}"
                );
            }
        }
    }
}

/// `gl-render --zink` of `overlap`'s depth as `glReadPixels(GL_DEPTH_COMPONENT, GL_FLOAT)`
/// returns it (`depth.f32`), without revz or through it in `mode` under the default policy
/// (`reverse_observable = copies`, `copy_values = standard`, which `gl-render` otherwise sets
/// to `stored` for its measurements), or `None` where Zink cannot be initialised.
fn zink_read_depth(
    harness: &Harness,
    zink: &Zink,
    mode: Option<&str>,
) -> Option<(Vec<f32>, String)> {
    let name = format!("zink-read-depth-{}{}", mode.unwrap_or("none"), zink.label());
    let out = harness.scratch_dir(&name);
    let mut command = zink.command(harness);
    command.args(["--scene", "overlap", "--out"]).arg(&out);
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
    for zink in Zink::all(&harness) {
        reads_depth_back(&harness, &zink);
    }
}

fn reads_depth_back(harness: &Harness, zink: &Zink) {
    let label = zink.label();
    let Some((native, _)) = zink_read_depth(harness, zink, None) else {
        return;
    };
    for mode in ["flip", "complementary", "infinite"] {
        let (depth, log) = zink_read_depth(harness, zink, Some(mode)).expect("Zink ran");
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
        eprintln!("zink{label} glReadPixels depth {mode}: worst difference {worst:e}");
        assert!(
            worst <= 2.4e-7,
            "{mode}{label}: depth read back {worst:e} from the run without revz\n{log}"
        );
    }
}

/// `gl-render --zink --post PASS` of `overlap` (`blit` or `mipmap`: depth a GL program derives
/// from the scene's depth, read back and sampled), without revz or through it in `mode` under
/// the default policy (`reverse_observable = copies`, `copy_values = standard`, which
/// `gl-render` otherwise sets to `stored`): the output directory and the layer's log, or
/// `None` where Zink cannot be initialised.
fn zink_post_outputs(
    harness: &Harness,
    zink: &Zink,
    pass: &str,
    mode: Option<&str>,
) -> Option<(std::path::PathBuf, String)> {
    let name = format!(
        "zink-post-{pass}-{}-default{}",
        mode.unwrap_or("none"),
        zink.label()
    );
    let out = harness.scratch_dir(&name);
    let mut command = zink.command(harness);
    command
        .args(["--scene", "overlap", "--post", pass, "--out"])
        .arg(&out);
    if let Some(mode) = mode {
        command
            .args(["--revz", mode])
            .env("REVZ_REVERSE_OBSERVABLE", "copies")
            .env("REVZ_COPY_VALUES", "standard")
            .env("REVZ_LOG", "info");
    }
    let stderr = run_gl_render(command, &name)?;
    Some((out, stderr))
}

/// A `.f32` file `gl-render` wrote (little-endian float32s).
fn read_f32(path: &std::path::Path) -> Vec<f32> {
    std::fs::read(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

/// A PNG `gl-render` wrote.
fn read_png(path: &std::path::Path) -> image::RgbaImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgba8()
}

/// The largest difference between two depth read-backs of the same size.
fn worst_difference(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len(), "depth read-backs of different sizes");
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max)
}

/// Times the layer's log says a depth image is reversed with a read twin.
fn twins_logged(log: &str) -> usize {
    log.matches("reversed, shaders read its twin").count()
}

/// Compares a `--post blit|mipmap` run through revz in `mode` with the run without it: the
/// post images (more than 16 pixels more than 2 levels apart) and the depth read back (more
/// than 2 float32 ulps below 1, 2.4e-7, from the run without revz); what differs, said.
fn post_outputs_differ(
    native: &std::path::Path,
    with: &std::path::Path,
    pass: &str,
    mode: &str,
    images: &[&str],
    depths: &[&str],
) -> Vec<String> {
    let mut problems = Vec::new();
    for file in images {
        let apart = far_apart(&read_png(&native.join(file)), &read_png(&with.join(file)));
        eprintln!("zink post {pass} {mode} {file}: {apart} of 65,536 pixels apart");
        if apart > 16 {
            problems.push(format!("{mode} {file}: {apart} pixels differ"));
        }
    }
    for file in depths {
        let (a, b) = (read_f32(&native.join(file)), read_f32(&with.join(file)));
        let worst = worst_difference(&a, &b);
        let off = a
            .iter()
            .zip(&b)
            .filter(|(x, y)| (*x - *y).abs() > 2.4e-7)
            .count();
        eprintln!(
            "zink post {pass} {mode} {file}: worst difference {worst:e}, {off} of {} values \
             off by more than 2.4e-7",
            a.len()
        );
        if worst > 2.4e-7 {
            problems.push(format!(
                "{mode} {file}: depth read back {worst:e} from the run without revz ({off} of \
                 {} values)",
                a.len()
            ));
        }
    }
    problems
}

/// Issue #39 through Zink: `glBlitFramebuffer` of depth (GL_NEAREST) into another depth
/// texture, as it is and mirrored, read back with glReadPixels and sampled by a fetch pass,
/// gives what it gives without revz, in every mode under the default policy: the scene's depth
/// image and both destinations are reversed with read twins (Mesa 22.3's Zink turns the
/// same-size blit into `vkCmdCopyImage` and the mirrored one into `vkCmdBlitImage`, both
/// between reversed images, which revz passes down as they are; the read-backs are converted
/// copies to a buffer, the fetches read the twins refreshed at the move to
/// `SHADER_READ_ONLY_OPTIMAL`).
#[test]
fn zink_blits_depth_as_it_does_without_revz() {
    let harness = Harness::locate();
    for zink in Zink::all(&harness) {
        blits_depth(&harness, &zink);
    }
}

fn blits_depth(harness: &Harness, zink: &Zink) {
    let Some((native, _)) = zink_post_outputs(harness, zink, "blit", None) else {
        return;
    };
    // The GL program did what it says: the copy is the scene's depth, the mirror its mirror.
    let depth = read_f32(&native.join("depth.f32"));
    let copy = read_f32(&native.join("blit-depth.f32"));
    let mirrored = read_f32(&native.join("blit-mirrored-depth.f32"));
    assert_eq!(
        copy, depth,
        "the blit without revz is not the scene's depth"
    );
    let width = 256;
    let unmirrored: Vec<f32> = mirrored
        .chunks_exact(width)
        .flat_map(|row| row.iter().rev().copied())
        .collect();
    assert_eq!(unmirrored, depth, "the mirrored blit is not the mirror");
    assert!(depth.iter().any(|&d| d < 0.99), "the scene drew nothing");

    let mut problems = Vec::new();
    for mode in ["flip", "complementary", "infinite"] {
        let (with, log) = zink_post_outputs(harness, zink, "blit", Some(mode)).expect("Zink ran");
        let twins = twins_logged(&log);
        if twins < 3 {
            problems.push(format!(
                "{mode}: {twins} depth images reversed with a twin, not the scene's and both \
                 blits'\n{log}"
            ));
        }
        problems.extend(post_outputs_differ(
            &native,
            &with,
            "blit",
            &format!("{mode}{}", zink.label()),
            &["post.png", "post-mirrored.png"],
            &["depth.f32", "blit-depth.f32", "blit-mirrored-depth.f32"],
        ));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Issue #39 through Zink: `glGenerateMipmap` of the scene's depth texture (a full chain from
/// glTexStorage2D, GL_NEAREST_MIPMAP_NEAREST), level 1 read back with glReadPixels and sampled
/// by a fetch pass (`texelFetch(.., 1)`), gives what it gives without revz, in every mode
/// under the default policy, the depth image reversed with a read twin. Mesa 22.3's Zink
/// generates the levels with u_blitter: one draw per level whose fragment shader samples the
/// level above and writes gl_FragDepth (its average: the 2 x 2 mean within 4.5e-8), the image
/// in `VK_IMAGE_LAYOUT_ATTACHMENT_FEEDBACK_LOOP_OPTIMAL_EXT`, sampled and attached at once.
/// Measured with the layer of a4b0bac: fails in every mode (level 1 reads back 0.0 for all
/// 16,384 texels, every post pixel off): no barrier into or within that layout refreshes the
/// twin (`policy::twins::shader_readable` does not count it), so u_blitter's draws sample the
/// twin never refreshed, and the levels they write (gl_FragDepth, converted by the rewritten
/// fragment shader) hold the reversed 0. Each level's draw samples the level the previous one
/// wrote, behind a barrier whose access is attachment reads and writes only.
#[test]
fn zink_generates_depth_mipmaps_as_it_does_without_revz() {
    let harness = Harness::locate();
    for zink in Zink::all(&harness) {
        generates_depth_mipmaps(&harness, &zink);
    }
}

fn generates_depth_mipmaps(harness: &Harness, zink: &Zink) {
    let Some((native, _)) = zink_post_outputs(harness, zink, "mipmap", None) else {
        return;
    };
    // Level 1 without revz lies within each 2 x 2 block of level 0 (a filtered reduction).
    let depth = read_f32(&native.join("depth.f32"));
    let level1 = read_f32(&native.join("mip1-depth.f32"));
    let (width, half) = (256, 128);
    assert_eq!(level1.len(), half * half);
    for (i, &d) in level1.iter().enumerate() {
        let (x, y) = (2 * (i % half), 2 * (i / half));
        let block = [
            depth[y * width + x],
            depth[y * width + x + 1],
            depth[(y + 1) * width + x],
            depth[(y + 1) * width + x + 1],
        ];
        let (lo, hi) = block
            .iter()
            .fold((f32::MAX, f32::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        assert!(
            d >= lo - 1e-6 && d <= hi + 1e-6,
            "level 1 texel {i} is {d}, outside its level-0 block {block:?}"
        );
    }

    let mut problems = Vec::new();
    for mode in ["flip", "complementary", "infinite"] {
        let (with, log) = zink_post_outputs(harness, zink, "mipmap", Some(mode)).expect("Zink ran");
        if twins_logged(&log) == 0 {
            problems.push(format!("{mode}: the depth image is not reversed\n{log}"));
        }
        problems.extend(post_outputs_differ(
            &native,
            &with,
            "mipmap",
            &format!("{mode}{}", zink.label()),
            &["post.png"],
            &["depth.f32", "mip1-depth.f32"],
        ));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The texels of OpenGL's UNORM depth textures read back exactly through Zink (found by
/// piglit's `depth-tex-compare`, docs/piglit.md): `gl-render --post texels` fills a
/// GL_DEPTH_COMPONENT16, a GL_DEPTH_COMPONENT24 and a GL_DEPTH24_STENCIL8 texture with
/// known texels (glTexImage2D: copies into images revz promotes to float32 and reverses in the
/// precise modes) and reads each texel with `texelFetch` and with shadow lookups (GL_LEQUAL,
/// GL_GEQUAL) against its own value. Through revz, under the default policy, in every mode,
/// every value read is bit for bit the one read without revz: the read twin of a promoted
/// image has the application's UNORM format, refreshed by a float32-to-UNORM conversion.
/// Measured with a float32 twin (session 34's layer): in `complementary` and `infinite`
/// 27,122 of 65,536 D16 texels and 57,349 of 65,536 D24 ones fetched an ulp apart, and
/// 13,548-40,965 lookups per format flipped between 0 and 1. The ground truth without revz:
/// each texel fetched within an ulp of its f64 value (`k / (2^bits - 1)`), and every lookup
/// against a reference equal to the fetched texel passes.
#[test]
fn zink_shaders_read_the_texels_of_unorm_depth_textures_as_without_revz() {
    let harness = Harness::locate();
    for zink in Zink::all(&harness) {
        if matches!(zink, Zink::NewerShaderObjects(_)) {
            // Texture reads: the same path as Mesa 25.0's Zink without separable programs.
            continue;
        }
        reads_texels(&harness, &zink);
    }
}

fn reads_texels(harness: &Harness, zink: &Zink) {
    let files = ["texels-d16.f32", "texels-d24.f32", "texels-d24s8.f32"];
    let Some((native, _)) = zink_post_outputs(harness, zink, "texels", None) else {
        return;
    };
    for file in files {
        let values = read_f32(&native.join(file));
        assert_eq!(values.len(), 256 * 256 * 4, "{file}");
        for texel in values.chunks_exact(4) {
            let [fetched, less_equal, greater_equal, reference] = texel else {
                unreachable!()
            };
            let ulp = f32::EPSILON * reference.max(f32::MIN_POSITIVE);
            assert!(
                (fetched - reference).abs() <= ulp,
                "{file}{}: fetched {fetched} for {reference}",
                zink.label()
            );
            // Against the fetched value itself one of the two holds whatever the rounding.
            assert!(
                *less_equal == 1.0 || *greater_equal == 1.0,
                "{file}{}: {texel:?}",
                zink.label()
            );
        }
    }
    let mut problems = Vec::new();
    for mode in ["flip", "complementary", "infinite"] {
        let (with, log) = zink_post_outputs(harness, zink, "texels", Some(mode)).expect("Zink ran");
        if !log.contains("D16_UNORM, 256x256): reversed")
            || log.matches("shaders read its twin").count() < 4
            || (mode != "flip" && !log.contains("promoted to D32_SFLOAT_S8_UINT"))
        {
            problems.push(format!(
                "{mode}{}: the textures are not reversed with twins (promoted in the precise \
                 modes)\n{log}",
                zink.label()
            ));
        }
        for file in files {
            let (a, b) = (read_f32(&native.join(file)), read_f32(&with.join(file)));
            let apart = a
                .iter()
                .zip(&b)
                .filter(|(x, y)| x.to_bits() != y.to_bits())
                .count();
            eprintln!(
                "zink texels {mode}{} {file}: {apart} of {} values differ",
                zink.label(),
                a.len()
            );
            if apart > 0 {
                problems.push(format!(
                    "{mode}{} {file}: {apart} values differ from the run without revz",
                    zink.label()
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// `gl-render --zink --reversed-z` of `scene`, through revz in `mode` or without it: the
/// color and depth read back, and the layer's log; `None` where Zink cannot be initialised.
fn zink_reversed_z(
    harness: &Harness,
    zink: &Zink,
    scene: &str,
    mode: Option<&str>,
) -> Option<(image::RgbaImage, Vec<f32>, String)> {
    let name = format!(
        "zink-reversed-z-{scene}-{}{}",
        mode.unwrap_or("none"),
        zink.label()
    );
    let out = harness.scratch_dir(&name);
    let mut command = zink.command(harness);
    command
        .args(["--reversed-z", "--scene", scene, "--out"])
        .arg(&out);
    if let Some(mode) = mode {
        command.args(["--revz", mode]);
    }
    let stderr = run_gl_render(command, &name)?;
    Some((
        read_png(&out.join("color.png")),
        read_f32(&out.join("depth.f32")),
        stderr,
    ))
}

/// An OpenGL application that renders reversed depth itself (`gl-render --reversed-z`:
/// `glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE)`, `glClearDepth(0)`, `GL_GREATER`, a
/// complementary projection into a float32 depth buffer), as piglit's
/// `arb_clip_control-depth-precision` does: revz leaves its depth alone in every mode, the
/// color and depth read back bit for bit those of the run without revz. Zink creates its
/// pipelines and sets its compare ops at the first draw, after the first clear, so revz saw
/// nothing but that clear to 0 when it decided the convention; before session 34 it decided
/// standard and reversed the application's depth again (D32 `sloped-plane` 14.3% and
/// `plane-stack` 31.5% wrong in `complementary` and `infinite`, against 0 and 1.08% without
/// revz).
#[test]
fn zink_leaves_an_application_that_reverses_depth_itself_alone() {
    let harness = Harness::locate();
    for zink in Zink::all(&harness) {
        for scene in ["sloped-plane", "plane-stack"] {
            let Some((color, depth, _)) = zink_reversed_z(&harness, &zink, scene, None) else {
                return;
            };
            for mode in ["flip", "complementary", "infinite"] {
                let what = format!("{scene} {mode} through Zink{}", zink.label());
                let (revz_color, revz_depth, log) =
                    zink_reversed_z(&harness, &zink, scene, Some(mode)).expect("Zink ran above");
                assert!(
                    log.contains("the application already uses reversed depth"),
                    "{what}: revz did not see the application's own reversal:\n{log}"
                );
                assert!(revz_color == color, "{what}: the colors differ");
                assert_eq!(
                    worst_difference(&depth, &revz_depth),
                    0.0,
                    "{what}: the depth differs"
                );
            }
        }
    }
}
