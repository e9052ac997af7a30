//! End-to-end: the tester on lavapipe, under the Khronos validation layer, with and without
//! revz. Every render must report zero validation messages (checked by `Harness::render`).

use std::process::Command;

use revz_tests::{
    differing_depths, differing_pixels, flip_color_tolerance, flip_tolerance,
    pixels_off_by_more_than, Harness, DEPTH_FORMATS, LAYER_NAME, MODES,
};

/// Renders `format` natively, then through the layer in every mode with
/// `reverse_observable = none`, and requires the layer's renders to be bit-identical: the
/// tester reads its depth image back (TRANSFER_SRC), so that image stays native in every
/// mode, and its draws must be left exactly as they are. (The default policy reverses it and
/// converts the copy: `tests/tests/copies.rs`.)
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
            .env("REVZ_REVERSE_OBSERVABLE", "none")
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

/// Flip mode with depth readback allowed (`reverse_observable=copies`): the color matches the
/// native render and the depth read back is 1 - the native depth within the format's
/// resolution.
fn flip_reverses_depth_and_keeps_color(format: &str) {
    flip_scene("overlap", format);
}

fn flip_scene(scene: &str, format: &str) -> String {
    flip_scene_with(scene, format, &[])
}

/// Renders `scene` natively and in flip mode (depth readback allowed), both with the tester
/// arguments `extra`, and compares them; returns the flip render's log.
fn flip_scene_with(scene: &str, format: &str, extra: &[&str]) -> String {
    flip_scene_within(scene, format, extra, &[], Tolerance::flip(format))
}

/// How far a render through the layer may be from 1 - the native one.
#[derive(Clone, Copy, Debug)]
struct Tolerance {
    /// The largest |(1 - native depth) - depth|.
    depth: f32,
    /// The most color pixels that may differ.
    color_pixels: usize,
}

impl Tolerance {
    /// The flip path's: the format's resolution ([`flip_tolerance`], [`flip_color_tolerance`]).
    fn flip(format: &str) -> Tolerance {
        Tolerance {
            depth: flip_tolerance(format),
            color_pixels: flip_color_tolerance(format),
        }
    }

    /// The flip path's with `extra` added to the depth bound.
    fn flip_plus(format: &str, extra: f32) -> Tolerance {
        let flip = Tolerance::flip(format);
        Tolerance {
            depth: flip.depth + extra,
            ..flip
        }
    }
}

/// [`flip_scene_with`] with the layer settings `settings` (environment variables) added and
/// the bounds `tolerance` instead of the format's flip-path ones.
fn flip_scene_within(
    scene: &str,
    format: &str,
    extra: &[&str],
    settings: &[(&str, &str)],
    tolerance: Tolerance,
) -> String {
    let harness = Harness::locate();
    // The arguments are part of both directory names: tests running at the same time render
    // the same scene and format with other arguments.
    let native_dir =
        harness.scratch_dir(&format!("flip-{scene}-{format}{}-native", extra.join("")));
    let mut command = harness.tester(format, &native_dir);
    command.args(["--scene", scene]).args(extra);
    let native = harness.render(command, &native_dir);
    let settings_name: String = settings.iter().map(|(_, value)| *value).collect();
    let dir = harness.scratch_dir(&format!(
        "flip-{scene}-{format}{}{settings_name}",
        extra.join("")
    ));
    let mut command = harness.tester(format, &dir);
    command.args(["--scene", scene]).args(extra);
    harness
        .with_layer(&mut command)
        .env("REVZ_MODE", "flip")
        .env("REVZ_REVERSE_OBSERVABLE", "copies")
        .env("REVZ_COPY_VALUES", "stored")
        .env("REVZ_LOG", "info")
        .envs(settings.iter().copied());
    let flipped = harness.render(command, &dir);
    let stderr = flipped.stderr();
    assert!(stderr.contains("): reversed"), "{scene} {format}: {stderr}");

    let differing = differing_pixels(&native.color(), &flipped.color());
    assert!(
        differing <= tolerance.color_pixels,
        "{scene} {format}: {differing} color pixels differ from the native render"
    );
    let (a, b) = (native.depth(), flipped.depth());
    let worst = a
        .iter()
        .zip(&b)
        .map(|(n, f)| ((1.0 - f64::from(*n)) - f64::from(*f)).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= f64::from(tolerance.depth),
        "{scene} {format}: depth differs from 1 - native by up to {worst:e} \
         (bound {:e})",
        tolerance.depth
    );
    stderr
}

/// One test per scene of the flip path, over every depth format the scene supports.
macro_rules! flip_scene_tests {
    ($($test:ident: $scene:literal, $formats:expr;)*) => {$(
        #[test]
        fn $test() {
            for format in $formats {
                flip_scene($scene, format);
            }
        }
    )*};
}

const STENCIL_FORMATS: [&str; 2] = ["d24-s8", "d32-s8"];

flip_scene_tests! {
    flip_compare_ops: "compare-ops", DEPTH_FORMATS;
    flip_compare_ops_dynamic: "compare-ops-dynamic", DEPTH_FORMATS;
    flip_compare_ops_unsorted: "compare-ops-unsorted", DEPTH_FORMATS;
    flip_clear_render_pass: "clear-render-pass", DEPTH_FORMATS;
    flip_clear_attachments: "clear-attachments", DEPTH_FORMATS;
    flip_clear_image: "clear-image", DEPTH_FORMATS;
    flip_depth_bias: "depth-bias", DEPTH_FORMATS;
    flip_depth_bias_dynamic: "depth-bias-dynamic", DEPTH_FORMATS;
    flip_viewport_sky: "viewport-sky", DEPTH_FORMATS;
    flip_viewport_split: "viewport-split", DEPTH_FORMATS;
    // Depth outside [0, 1] (VK_EXT_depth_range_unrestricted): viewports, a clear and a clamped
    // draw; read back unclamped from the float formats, clamped alike from the UNORM ones.
    flip_depth_range_unrestricted: "depth-range-unrestricted", DEPTH_FORMATS;
    flip_depth_range_unrestricted_clear_one: "depth-range-unrestricted-clear-one", DEPTH_FORMATS;
    flip_stencil: "stencil", STENCIL_FORMATS;
    flip_secondary: "secondary", DEPTH_FORMATS;
    // The shadow casters drawn from secondaries without a framebuffer land in the map, which is
    // reversed and read through its twin like the main attachment (issue #39): a guess by
    // format is right either way since both D32 images are reversed.
    flip_shadow_map_secondaries: "shadow-map-secondaries", DEPTH_FORMATS;
    flip_subpasses: "subpasses", DEPTH_FORMATS;
    flip_dynamic_rendering: "dynamic-rendering", DEPTH_FORMATS;
    // One rendering recorded as a suspended and a resuming instance (session 38).
    flip_dynamic_rendering_suspended: "dynamic-rendering-suspended", DEPTH_FORMATS;
    // Resumed in a second primary command buffer of the same batch.
    flip_dynamic_rendering_suspended_across: "dynamic-rendering-suspended-across", DEPTH_FORMATS;
    // Secondaries on threads inheriting only the rendering's formats (session 38).
    flip_dynamic_rendering_secondaries: "dynamic-rendering-secondaries", DEPTH_FORMATS;
    flip_frag_depth: "frag-depth", DEPTH_FORMATS;
    flip_pipeline_library: "pipeline-library", DEPTH_FORMATS;
    flip_frag_depth_library: "frag-depth-library", DEPTH_FORMATS;
    // The same libraries in a dynamic rendering, as DXVK makes them (session 38).
    flip_pipeline_library_dynamic: "pipeline-library-dynamic", DEPTH_FORMATS;
    flip_frag_depth_library_dynamic: "frag-depth-library-dynamic", DEPTH_FORMATS;
}

/// The shadow map is sampled: it is reversed all the same (its clear, compare op, depth bias
/// and viewport follow), and the receiver samples its read twin, refreshed with standard
/// values when the shadow pass ends (issue #39): the shadows land where they do without the
/// layer (`flip_scene` compares the colors), through a comparison sampler (`shadow-map`) and
/// through texel fetches and a plain sampler whose raw values the shader compares itself
/// (`shadow-map-raw`: reversed values would shadow nearly everything), and with an X8_D24 map
/// (`shadow-map-x8-d24`: its twin is X8_D24, the image promoted to float in the precise
/// modes, which the copies tests render), and lit by a spot light (`shadow-map-perspective`:
/// a perspective shadow pass, whose map the precise modes store with the light's own n / w).
#[test]
fn flip_shadow_map_is_reversed_and_sampled_through_its_twin() {
    for (scene, map) in [
        ("shadow-map", "D32_SFLOAT"),
        ("shadow-map-raw", "D32_SFLOAT"),
        ("shadow-map-x8-d24", "X8_D24_UNORM_PACK32"),
        ("shadow-map-perspective", "D32_SFLOAT"),
    ] {
        for format in DEPTH_FORMATS {
            let log = flip_scene(scene, format);
            assert!(
                log.contains(&format!("{map}, 512x512): reversed, shaders read its twin")),
                "{scene} {format}: {log}"
            );
            assert!(
                !log.contains("read twin is not refreshed"),
                "{scene} {format}: {log}"
            );
        }
    }
}

/// `depth-reads` (issue #39): the main depth image, which soft particles sample while it is
/// attached read-only (a descriptor set written with `vkUpdateDescriptorSets`) and a post pass
/// samples afterwards (texel fetch, sampler, gather; descriptors pushed with
/// `vkCmdPushDescriptorSetKHR`), is
/// reversed and read through its twin in every mode and depth format, with zero validation
/// messages (synchronization validation included), and the colors are the native render's:
/// the particles' fades and the post band are computed from the depth the shaders read, so
/// reversed values, or a twin not refreshed before the particles' pass, change thousands of
/// pixels. The twin is refreshed once per frame (before the particles' pass: its implicit
/// transition into the read-only layout makes the image readable; nothing writes it until
/// the barrier into the post pass's layout, which refreshes nothing).
///
/// The reference: the native render of the same format, the UNORM formats revz promotes to
/// float in the precise modes included (their read twin is UNORM: the particles fade with the
/// depth the application's format holds; before session 35 the twin was float32, and D16
/// renders matched native D32's instead). Allowed: channels 1 level off (rounding of the
/// depth converted back, in the fades), and per format the pixels where a particle meets a
/// surface closer than the depth resolution (2, seen 1; D16: the flip path's allowance, and
/// where promoted, [`read_color_problems`]' wider one, with the ground-truth check that
/// explains it: the D16 values revz hands back are the f64 truth rounded at least as often as
/// lavapipe's own D16 rasterization's).
#[test]
fn depth_reads_sample_standard_depth_through_the_twin() {
    let harness = Harness::locate();
    let frames = "2";
    let native = |format: &str| {
        let dir = harness.scratch_dir(&format!("depth-reads-{format}-native"));
        let mut command = harness.tester(format, &dir);
        command.args(["--scene", "depth-reads", "--sync-validation"]);
        let render = harness.render(command, &dir);
        (render.color(), render.depth())
    };
    for format in DEPTH_FORMATS {
        let (own, own_depth) = native(format);
        for mode in ["flip", "complementary", "infinite"] {
            let name = format!("depth-reads-{format}-{mode}");
            let dir = harness.scratch_dir(&name);
            let report = dir.join("profile.json");
            let mut command = harness.tester(format, &dir);
            command.args([
                "--scene",
                "depth-reads",
                "--sync-validation",
                "--frames",
                frames,
            ]);
            harness
                .with_layer(&mut command)
                .env("REVZ_MODE", mode)
                .env("REVZ_LOG", "info")
                .env("REVZ_REPORT", &report);
            let render = harness.render(command, &dir);
            let log = render.stderr();
            assert!(log.contains("shaders read its twin"), "{name}: {log}");
            // The post pass pushes its descriptors (lavapipe has VK_KHR_push_descriptor): the
            // pushed view is the twin's, or the band would shade reversed depth.
            let features = render.json()["features"].to_string();
            assert!(
                features.contains("VK_KHR_push_descriptor"),
                "{name}: {features}"
            );
            let problems = read_color_problems(&name, (format, mode), &own, &render.color());
            assert!(problems.is_empty(), "{}", problems.join("\n"));
            if promoted_d16(format, mode) {
                // What shaders read is what copies read back (one conversion into D16): the
                // f64 truth rounded to D16 at least as often as without revz.
                let truth = render.ground_truth();
                let (with, without) = (
                    rounds_the_truth(&render.depth(), &truth),
                    rounds_the_truth(&own_depth, &truth),
                );
                eprintln!(
                    "{name}: D16 read back as the rounded truth at {with} of {} interior pixels \
                     ({without} without revz)",
                    truth.interior()
                );
                assert!(with >= without, "{name}: {with} < {without}");
            }
            let profile: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&report).expect("the profile"))
                    .expect("a JSON profile");
            let image = &profile["images"][0];
            assert_eq!(image["read_twin"], true, "{name}: {image}");
            assert_eq!(image["depth"], "reversed", "{name}: {image}");
            assert_eq!(
                image["refreshes_recorded"].as_u64(),
                frames.parse().ok(),
                "{name}: one refresh a frame: {image}"
            );
        }
    }
}

/// `depth-reads` with its depth pyramid's compute pipeline and descriptors bound at the start
/// of the recording (`--bind-tiles-first`), as a frame whose culling pass binds its compute
/// state first: the dispatch after the passes binds nothing, so the compute state revz's
/// refreshes disturb (their conversion is a dispatch) must be bound again after them. With
/// descriptor sets; with a descriptor buffer (`VK_EXT_descriptor_buffer`, on the newer
/// lavapipe: what vkd3d-proton binds for every dispatch, and Zink on drivers with the
/// extension), whose view of the depth image `vkGetDescriptorEXT` makes the read twin's; and
/// with push descriptors, written (`vkCmdPushDescriptorSetKHR`) or through an update template
/// (`vkCmdPushDescriptorSetWithTemplateKHR`), which revz pushes again as the writes it sent;
/// with the set, the compute program a shader object (`vkCmdBindShadersEXT`, newer lavapipe);
/// and with the set or the descriptor buffer's offsets bound by `VK_KHR_maintenance6`'s
/// commands (`vkCmdBindDescriptorSets2KHR`, `vkCmdSetDescriptorBufferOffsets2EXT`; the
/// installed validation layer predates these extensions and is left out for them). In
/// every mode, D32 and D24S8 (promoted in the precise modes), with zero validation messages
/// (synchronization validation included), no refresh or copy is left unconverted, the colors
/// are those of `depth-reads` through revz, to the pixel, and so the native render's within
/// `depth-reads`' bound, and the native render itself is `depth-reads`' (the early bind
/// changes nothing without revz). Before session 36
/// revz could bind neither descriptor buffer offsets, pushed descriptors nor a compute shader
/// object again and refused every conversion after them: D32 `infinite` 40,719 pixels wrong
/// with each, the twin never refreshed (a layout error from validation), the depth read back
/// reversed; and `vkCmdSetDescriptorBufferOffsets2EXT`, which revz did not hook, crashed the
/// application (revz dispatched, the offsets it did not know of were left invalid, and the
/// application's next dispatch read garbage: a segmentation fault in lavapipe).
#[test]
fn depth_reads_whose_compute_state_is_bound_first_keep_it_across_refreshes() {
    let harness = Harness::locate();
    let mut problems = Vec::new();
    let ways = [
        "sets",
        "buffer",
        "push",
        "push-template",
        "shader-object",
        "sets2",
        "buffer2",
    ];
    for descriptors in ways {
        for format in ["d32", "d24-s8"] {
            let render = |mode: Option<&str>, bind_first: bool| {
                let name = format!(
                    "depth-reads-{}-{format}-{}",
                    if bind_first { descriptors } else { "plain" },
                    mode.unwrap_or("native")
                );
                let dir = harness.scratch_dir(&name);
                let mut command = harness.tester(format, &dir);
                command.args([
                    "--scene",
                    "depth-reads",
                    "--sync-validation",
                    "--frames",
                    "2",
                ]);
                if bind_first {
                    command.args(["--bind-tiles-first", descriptors]);
                }
                // Descriptor buffers, shader objects, maintenance6: lavapipe 22.3 has none.
                if matches!(
                    descriptors,
                    "buffer" | "shader-object" | "sets2" | "buffer2"
                ) {
                    harness.on_newer_lavapipe(&mut command);
                }
                if let Some(mode) = mode {
                    harness
                        .with_layer(&mut command)
                        .env("REVZ_MODE", mode)
                        .env("REVZ_LOG", "info");
                }
                (name, harness.render(command, &dir))
            };
            let (_, plain) = render(None, false);
            let (name, native) = render(None, true);
            let differing = differing_pixels(&plain.color(), &native.color());
            if differing != 0 {
                problems.push(format!(
                    "{name}: {differing} pixels differ from depth-reads'"
                ));
            }
            if descriptors == "buffer" {
                let features = native.json()["features"].to_string();
                assert!(features.contains("descriptorBuffer"), "{name}: {features}");
            }
            for mode in ["flip", "complementary", "infinite"] {
                let (name, layered) = render(Some(mode), true);
                let log = layered.stderr();
                if log.contains("not refreshed") || log.contains("not converted") {
                    problems.push(format!("{name}: a conversion was refused: {log}"));
                }
                // What revz hands the shaders does not depend on when the application bound
                // its compute state: the render of `depth-reads` through revz, to the pixel.
                let (_, layered_plain) = render(Some(mode), false);
                let differing = differing_pixels(&layered_plain.color(), &layered.color());
                if differing != 0 {
                    problems.push(format!(
                        "{name}: {differing} pixels differ from depth-reads' through revz"
                    ));
                }
                // And that render is the native one within `depth-reads`' bound (Mesa 25.0's
                // lavapipe rounds more fades one level apart than Mesa 22.3's: 211 pixels in
                // D24S8 `infinite`, against 125, none more than one level).
                let loose = pixels_off_by_more_than(&native.color(), &layered.color(), 1);
                if loose > 2 {
                    problems.push(format!("{name}: {loose} pixels off by more than one level"));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// `stencil-reads` (issue #39): a depth-stencil image whose stencil aspect a post pass samples
/// (beside its depth) is reversed and read through its twin in every mode, with zero
/// validation messages, and the band shaded from both aspects is the native render's: the
/// twin keeps the stencil as it is (a refresh that copied the stencil after the converted
/// depth left lavapipe's twin with raw reversed depth; one that lost the stencil would shade
/// the band as background). Reference: the native render of the same format, in the precise
/// modes too, where the D24S8 image is promoted (stored as D32S8) and its twin is D24S8, its
/// stencil carried through the conversion with the depth (before session 35 the twin was
/// D32S8, and native D32S8's render the reference).
#[test]
fn stencil_reads_sample_the_stencil_and_depth_of_the_twin() {
    let harness = Harness::locate();
    let native = |format: &str| {
        let dir = harness.scratch_dir(&format!("stencil-reads-{format}-native"));
        let mut command = harness.tester(format, &dir);
        command.args(["--scene", "stencil-reads", "--sync-validation"]);
        harness.render(command, &dir).color()
    };
    for format in STENCIL_FORMATS {
        let own = native(format);
        for mode in ["flip", "complementary", "infinite"] {
            let name = format!("stencil-reads-{format}-{mode}");
            let dir = harness.scratch_dir(&name);
            let mut command = harness.tester(format, &dir);
            command.args(["--scene", "stencil-reads", "--sync-validation"]);
            harness
                .with_layer(&mut command)
                .env("REVZ_MODE", mode)
                .env("REVZ_LOG", "info");
            let render = harness.render(command, &dir);
            let log = render.stderr();
            assert!(log.contains("shaders read its twin"), "{name}: {log}");
            let color = render.color();
            let loose = pixels_off_by_more_than(&own, &color, 1);
            assert!(
                loose <= 2,
                "{name}: {loose} pixels differ by more than 1 level"
            );
            let differing = differing_pixels(&own, &color);
            eprintln!("{name}: {loose} pixels off by more than 1 level, {differing} differing");
            assert!(differing <= 20, "{name}: {differing} pixels differ");
        }
    }
}

/// The depth resolve modes lavapipe supports (`supportedDepthResolveModes`; MIN and MAX are
/// for real GPUs).
const LAVAPIPE_DEPTH_RESOLVES: [&str; 2] = ["sample-zero", "average"];

/// Whether lavapipe can resolve `format` with depth resolve `mode`. It lacks
/// `independentResolveNone`, so the stencil aspect of d24-s8 and d32-s8 must be resolved with
/// the depth mode, and AVERAGE is never a stencil mode: those formats take sample-zero only
/// (the tester refuses the rest: `unsupported_depth_resolves_are_refused`).
fn lavapipe_resolves(format: &str, mode: &str) -> bool {
    mode == "sample-zero" || !STENCIL_FORMATS.contains(&format)
}

/// The Vulkan name of a `--depth-resolve` value, as `render.json` reports it.
fn resolve_vk_name(mode: &str) -> String {
    mode.replace('-', "_").to_uppercase()
}

/// The multisampled scenes (`msaa-resolve`: `vkCreateRenderPass2` with
/// `VkSubpassDescriptionDepthStencilResolve`; `msaa-resolve-dynamic`: dynamic rendering's
/// `resolveMode` / `resolveImageView`) resolve a transient 4x depth attachment into the depth
/// image the tester reads back.
///
/// With `reverse_observable = none`: the 4x depth attachment is not observable, so the layer
/// may reverse it, but it is resolved into the read-back depth image, which stays native: the
/// layer
/// must make the 4x image native too (logged, at info, as `resolved into native`), so every
/// mode renders both color and depth bit-identical to the native render, for every depth
/// format and each depth resolve mode lavapipe supports for it. (`off` passes everything
/// through and decides nothing: no line is asked of it.)
fn msaa_resolve_into_native_is_bit_identical(scene: &str) {
    let harness = Harness::locate();
    for format in DEPTH_FORMATS {
        for resolve in LAVAPIPE_DEPTH_RESOLVES {
            if !lavapipe_resolves(format, resolve) {
                continue;
            }
            let args = ["--scene", scene, "--depth-resolve", resolve];
            let name = format!("{scene}-{format}-{resolve}");
            let native_dir = harness.scratch_dir(&format!("{name}-native"));
            let mut command = harness.tester(format, &native_dir);
            command.args(args);
            let native = harness.render(command, &native_dir);
            let json = native.json();
            assert_eq!(json["multisample"]["samples"], 4, "{name}: {json}");
            assert_eq!(
                json["multisample"]["depth_resolve"],
                resolve_vk_name(resolve).as_str(),
                "{name}: {json}"
            );
            assert!(
                json["covered_pixels"].as_u64().unwrap() > 1000,
                "{name}: the scene barely covers the image: {json}"
            );
            let (native_color, native_depth) = (native.color(), native.depth());
            for mode in MODES {
                let dir = harness.scratch_dir(&format!("{name}-{mode}"));
                let mut command = harness.tester(format, &dir);
                command.args(args);
                harness
                    .with_layer(&mut command)
                    .env("REVZ_MODE", mode)
                    .env("REVZ_REVERSE_OBSERVABLE", "none")
                    .env("REVZ_LOG", "info");
                let layered = harness.render(command, &dir);
                let log = layered.stderr();
                assert_eq!(
                    layered.loaded_mode().as_deref(),
                    Some(mode),
                    "{name}: {log}"
                );
                if mode != "off" {
                    assert!(
                        log.contains("resolved into native"),
                        "{name}, mode {mode}: the 4x depth image was not made native\n{log}"
                    );
                }
                assert_eq!(
                    differing_pixels(&native_color, &layered.color()),
                    0,
                    "{name}, mode {mode}: color differs from the native render\n{log}"
                );
                assert_eq!(
                    differing_depths(&native_depth, &layered.depth()),
                    0,
                    "{name}, mode {mode}: depth differs from the native render\n{log}"
                );
            }
        }
    }
}

#[test]
fn msaa_resolve_into_native_depth_is_bit_identical() {
    msaa_resolve_into_native_is_bit_identical("msaa-resolve");
}

#[test]
fn msaa_resolve_dynamic_into_native_depth_is_bit_identical() {
    msaa_resolve_into_native_is_bit_identical("msaa-resolve-dynamic");
}

/// How far an AVERAGE depth resolve of flipped samples may lie from 1 - the native resolve,
/// beyond [`flip_tolerance`]: the mean of the samples is rounded to the format in each render,
/// the mean of D and the mean of 1 - D independently. Fixed-point formats: one step of the
/// grid (lavapipe's AVERAGE of x8-d24 lands one step above its SAMPLE_ZERO at every covered
/// pixel, and the flipped render was measured 3.01 steps from 1 - native, past the 3 of
/// `flip_tolerance`). Float formats: the mean of four values in [0, 1] in float32, three
/// additions below 4 (half an ulp each, 2^-22, quartered by the exact division) and the final
/// rounding below 1 (2^-24): 3 * 2^-24 + 2^-24 = 2.4e-7. (lavapipe's AVERAGE of d16 and d32
/// equals its SAMPLE_ZERO here, so only x8-d24 uses the margin today.)
fn average_resolve_rounding(format: &str) -> f32 {
    match format {
        "d16" => 1.0 / 65535.0,
        "x8-d24" | "d24-s8" => 1.0 / 16_777_215.0,
        _ => 2.4e-7,
    }
}

/// Flip mode with depth readback allowed (`reverse_observable=copies`): the read-back depth
/// image is reversed, so the 4x one stays reversed (no `resolved into native`), and the
/// render must keep the native colors with the depth read back 1 - the native depth: within
/// [`flip_tolerance`] for SAMPLE_ZERO (it picks the same sample), within that plus
/// [`average_resolve_rounding`] for AVERAGE (the mean commutes with d -> 1 - d up to
/// rounding). Every depth format, each resolve mode lavapipe supports for it.
fn flip_msaa_scene(scene: &str) {
    for format in DEPTH_FORMATS {
        for resolve in LAVAPIPE_DEPTH_RESOLVES {
            if !lavapipe_resolves(format, resolve) {
                continue;
            }
            let rounding = if resolve == "average" {
                average_resolve_rounding(format)
            } else {
                0.0
            };
            let tolerance = Tolerance::flip_plus(format, rounding);
            let log =
                flip_scene_within(scene, format, &["--depth-resolve", resolve], &[], tolerance);
            assert!(
                !log.contains("resolved into native"),
                "{scene} {format} {resolve}: the 4x depth image was made native although its \
                 resolve target is reversed\n{log}"
            );
        }
    }
}

#[test]
fn flip_msaa_resolve() {
    flip_msaa_scene("msaa-resolve");
}

#[test]
fn flip_msaa_resolve_dynamic() {
    flip_msaa_scene("msaa-resolve-dynamic");
}

/// The tester refuses, with one clear error and no render, a depth resolve mode the device
/// lacks (lavapipe: MIN and MAX), AVERAGE on a stencil format where the device cannot resolve
/// depth alone, and `--depth-resolve` for a scene without a multisampled pass.
#[test]
fn unsupported_depth_resolves_are_refused() {
    let harness = Harness::locate();
    let cases = [
        (
            "msaa-resolve",
            "d32",
            "min",
            "cannot resolve depth with MIN (--depth-resolve min)",
        ),
        (
            "msaa-resolve-dynamic",
            "d16",
            "max",
            "cannot resolve depth with MAX (--depth-resolve max)",
        ),
        (
            "msaa-resolve",
            "d24-s8",
            "average",
            "cannot resolve D24_UNORM_S8_UINT with depth mode AVERAGE",
        ),
        (
            "msaa-resolve-dynamic",
            "d32-s8",
            "average",
            "cannot resolve D32_SFLOAT_S8_UINT with depth mode AVERAGE",
        ),
        (
            "overlap",
            "d32",
            "sample-zero",
            "scene 'overlap' has no multisampled pass",
        ),
    ];
    for (scene, format, resolve, error) in cases {
        let dir = harness.scratch_dir(&format!("refused-{scene}-{format}-{resolve}"));
        let mut command = harness.tester(format, &dir);
        command.args(["--scene", scene, "--depth-resolve", resolve]);
        let output = command.output().expect("run the tester");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(
            output.status.code(),
            Some(1),
            "{scene} {format} {resolve}: {stderr}"
        );
        assert!(
            stderr.contains(error),
            "{scene} {format} {resolve}: {stderr}"
        );
        assert_eq!(
            stderr.lines().filter(|l| l.contains("error")).count(),
            1,
            "{stderr}"
        );
        assert!(
            !dir.join("render.json").exists(),
            "{scene} {format} {resolve}"
        );
    }
}

/// An application that asks for Vulkan 1.2 has no core dynamic compare op: revz enables
/// `VK_EXT_extended_dynamic_state` for it, and the flip path works the same (validation would
/// report the extension's commands if the extension were not enabled).
#[test]
fn applications_below_vulkan_1_3_get_extended_dynamic_state() {
    for scene in ["overlap", "compare-ops", "viewport-split"] {
        let log = flip_scene_with(scene, "d32", &["--vulkan", "1.2"]);
        assert!(
            log.contains("enabled VK_EXT_extended_dynamic_state"),
            "{scene}: {log}"
        );
    }
}

/// Without depth readback the main attachment is not observable: the default policy reverses
/// it (and, in the multisampled scenes, the 4x attachment resolved into it, which then stays
/// reversed), and the color still matches the native render.
#[test]
fn unobservable_attachments_are_reversed_by_default() {
    let harness = Harness::locate();
    for scene in [
        "overlap",
        "shadow-map",
        "secondary",
        "msaa-resolve",
        "msaa-resolve-dynamic",
    ] {
        let native_dir = harness.scratch_dir(&format!("unobserved-{scene}-native"));
        let mut command = harness.tester("d32", &native_dir);
        command.args(["--scene", scene, "--no-depth-readback"]);
        let native = harness.render(command, &native_dir);
        let dir = harness.scratch_dir(&format!("unobserved-{scene}"));
        let mut command = harness.tester("d32", &dir);
        command.args(["--scene", scene, "--no-depth-readback"]);
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", "flip")
            .env("REVZ_LOG", "info");
        let flipped = harness.render(command, &dir);
        let log = flipped.stderr();
        assert!(
            log.contains("(D32_SFLOAT, 256x256): reversed"),
            "{scene}: {log}"
        );
        assert!(!log.contains("resolved into native"), "{scene}: {log}");
        assert_eq!(
            differing_pixels(&native.color(), &flipped.color()),
            0,
            "{scene}"
        );
    }
}

/// lavapipe has no `depthBounds`: the scene refuses to run there (the state item is covered by
/// the command-state unit tests, and runs on devices that have the feature).
#[test]
fn depth_bounds_scene_needs_the_feature() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("depth-bounds");
    let mut command = harness.tester("d32", &dir);
    command.args(["--scene", "depth-bounds"]);
    let output = command.output().expect("run the tester");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("device lacks depthBounds"), "{stderr}");
}

#[test]
fn flip_d16() {
    flip_reverses_depth_and_keeps_color("d16");
}

#[test]
fn flip_x8_d24() {
    flip_reverses_depth_and_keeps_color("x8-d24");
}

#[test]
fn flip_d24_s8() {
    flip_reverses_depth_and_keeps_color("d24-s8");
}

#[test]
fn flip_d32() {
    flip_reverses_depth_and_keeps_color("d32");
}

#[test]
fn flip_d32_s8() {
    flip_reverses_depth_and_keeps_color("d32-s8");
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

/// `cargo xtask install` installs the implicit layer for the user: off unless `ENABLE_REVZ=1`,
/// `DISABLE_REVZ=1` wins, and `cargo xtask uninstall` removes it.
#[test]
fn install_enable_disable_uninstall() {
    let harness = Harness::locate();
    let data_home = harness.scratch_dir("install-data-home");
    let xtask = |task: &str| {
        let args: &[&str] = match task {
            "install" => &["install", "--debug", "--no-build"],
            _ => &[task],
        };
        let output = harness
            .xtask()
            .args(args)
            .env("XDG_DATA_HOME", &data_home)
            .output()
            .expect("run xtask");
        let text = String::from_utf8_lossy(&output.stdout).into_owned()
            + &String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "xtask {task}: {text}");
        text
    };
    let manifest = data_home.join("vulkan/implicit_layer.d/VkLayer_revz.json");
    let library = data_home.join("revz/libVkLayer_revz.so");
    xtask("install");
    assert!(manifest.exists() && library.exists());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&manifest).unwrap()).unwrap();
    assert_eq!(json["layer"]["library_path"], library.to_str().unwrap());

    let vulkaninfo = |env: &[(&str, &str)]| {
        let output = revz_tests::clean_command("vulkaninfo".as_ref())
            .arg("--summary")
            .env("XDG_DATA_HOME", &data_home)
            .env("REVZ_LOG", "info")
            .envs(env.iter().copied())
            .output()
            .expect("vulkaninfo is missing: apt-get install vulkan-tools");
        assert!(output.status.success());
        (
            String::from_utf8_lossy(&output.stdout).into_owned(),
            String::from_utf8_lossy(&output.stderr).into_owned(),
        )
    };
    let (stdout, stderr) = vulkaninfo(&[("ENABLE_REVZ", "1")]);
    assert!(stdout.contains(LAYER_NAME), "{stdout}");
    assert!(
        stderr.contains("loaded as VK_LAYER_REVZ_reverse_z"),
        "{stderr}"
    );
    let (_, stderr) = vulkaninfo(&[]);
    assert!(
        !stderr.contains("loaded as"),
        "active without ENABLE_REVZ: {stderr}"
    );
    let (_, stderr) = vulkaninfo(&[("ENABLE_REVZ", "1"), ("DISABLE_REVZ", "1")]);
    assert!(
        !stderr.contains("loaded as"),
        "DISABLE_REVZ did not win: {stderr}"
    );

    // A render through the installed layer is still clean.
    let dir = harness.scratch_dir("installed-render");
    let mut command = harness.tester("d32", &dir);
    command
        .env("XDG_DATA_HOME", &data_home)
        .env("ENABLE_REVZ", "1")
        .env("REVZ_LOG", "info");
    assert!(harness.render(command, &dir).loaded_mode().is_some());

    let text = xtask("uninstall");
    assert!(!manifest.exists() && !library.exists(), "{text}");
    assert!(xtask("uninstall").contains("was not installed"));
}

/// `cargo xtask run --mode M -- PROGRAM` injects revz into one program, nothing installed.
#[test]
fn run_injects_the_layer_with_the_chosen_mode() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("xtask-run");
    let mut command = harness.xtask();
    command
        .args([
            "run",
            "--debug",
            "--no-build",
            "--mode",
            "infinite",
            "--log",
            "info",
            "--",
        ])
        .arg(&harness.tester)
        .args(harness.tester_args("d32", &dir));
    let render = harness.render(command, &dir);
    assert_eq!(render.loaded_mode().as_deref(), Some("infinite"));
}

/// A config file with a per-application section for the tester (matched by executable name,
/// and by `VkApplicationInfo` name) sets the mode; the environment still wins over it.
#[test]
fn config_file_sections_match_the_application() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("config-file");
    let config = dir.join("revz.toml");
    let cases = [
        ("executable = \"revz-tester\"", None, "infinite"),
        ("application_name = \"revz-tester\"", None, "infinite"),
        ("engine_name = \"another-engine\"", None, "flip"),
        ("executable = \"revz-tester\"", Some("off"), "off"),
    ];
    for (matcher, env_mode, expected) in cases {
        std::fs::write(
            &config,
            format!("mode = \"flip\"\n\n[[application]]\n{matcher}\nmode = \"infinite\"\n"),
        )
        .unwrap();
        let out = dir.join("render");
        let mut command = harness.tester("d32", &out);
        harness
            .with_layer(&mut command)
            .env("REVZ_CONFIG", &config)
            .env("REVZ_LOG", "info");
        if let Some(mode) = env_mode {
            command.env("REVZ_MODE", mode);
        }
        let render = harness.render(command, &out);
        assert_eq!(
            render.loaded_mode().as_deref(),
            Some(expected),
            "{matcher} / {env_mode:?}: {}",
            render.stderr()
        );
    }
}

/// A broken config file: one warning with the file and line, and the layer keeps running with
/// the defaults for what it could not read.
#[test]
fn bad_config_files_warn_with_file_and_line_and_the_layer_carries_on() {
    let harness = Harness::locate();
    let dir = harness.scratch_dir("bad-config");
    let config = dir.join("revz.toml");
    let path = config.display().to_string();
    let cases = [
        (
            "far_clip = \"keep\"\nmode = [\n",
            format!("{path}:2: not valid TOML ("),
            "complementary",
        ),
        (
            "mode = \"flip\"\ncolour = \"red\"\n",
            format!("{path}:2: unknown key 'colour' (settings: mode, far_clip,"),
            "flip",
        ),
        (
            "mode = \"sideways\"\n",
            format!(
                "{path}:1: 'sideways' is not a valid mode \
                 (expected one of: off, flip, complementary, infinite); using off"
            ),
            "off",
        ),
    ];
    for (text, warning, mode) in cases {
        std::fs::write(&config, text).unwrap();
        let out = dir.join("render");
        let mut command = harness.tester("d32", &out);
        harness
            .with_layer(&mut command)
            .env("REVZ_CONFIG", &config)
            .env("REVZ_LOG", "info");
        let render = harness.render(command, &out);
        let stderr = render.stderr();
        assert_eq!(stderr.matches("[revz WARN]").count(), 1, "{stderr}");
        assert!(
            stderr.contains(&warning),
            "expected {warning:?} in\n{stderr}"
        );
        assert_eq!(render.loaded_mode().as_deref(), Some(mode), "{stderr}");
    }

    // A config file that cannot be read.
    let out = dir.join("render");
    let mut command = harness.tester("d32", &out);
    harness
        .with_layer(&mut command)
        .env("REVZ_CONFIG", &dir)
        .env("REVZ_LOG", "warn");
    let stderr = harness.render(command, &out).stderr();
    assert!(
        stderr.contains(&format!("{}: cannot read the config file (", dir.display())),
        "{stderr}"
    );
}

/// `compare_op = variants`, what a device without Vulkan 1.3 or
/// `VK_EXT_extended_dynamic_state` gets: compare ops stay static and revz binds a variant of
/// each pipeline with the flipped op for draws into reversed attachments (and the
/// application's pipeline for native ones, as in `shadow-map`'s light pass). Same bounds as
/// the dynamic flip path; a variant not bound would invert every occlusion.
#[test]
fn flip_with_compare_op_variants() {
    let variants = [("REVZ_COMPARE_OP", "variants")];
    let scenes = [
        ("overlap", "d32"),
        ("compare-ops", "d32"),
        ("compare-ops", "d16"),
        ("depth-bias", "d32"),
        ("viewport-sky", "d32"),
        ("secondary", "d32"),
        ("subpasses", "d32"),
        ("dynamic-rendering", "d32"),
        ("shadow-map", "d32"),
        ("stencil", "d32-s8"),
    ];
    for (scene, format) in scenes {
        let log = flip_scene_within(scene, format, &[], &variants, Tolerance::flip(format));
        assert!(log.contains("compare_op=variants"), "{scene}: {log}");
    }
}

/// The precise modes bind the rewritten fragment shader too. Complementary Z stores 1 - D, so
/// the render matches 1 - native as the flip path's does (to the rounding of the rewritten
/// projection, a few float32 steps). Infinite mode stores n/w = 1 - (1 - n/f) D for the cards
/// drawn without FragDepth but 1 - x for the rewritten shader's (it bakes one map, the
/// complementary one): those depths differ from 1 - native by up to n/f = 1e-3 for this
/// camera, while the colors, decided by margins of 4.7e-3 and more, stay the same.
#[test]
fn precise_modes_rewrite_frag_depth() {
    for format in DEPTH_FORMATS {
        let settings = [("REVZ_MODE", "complementary")];
        let tolerance = Tolerance::flip_plus(format, 4.0 * f32::EPSILON);
        flip_scene_within("frag-depth", format, &[], &settings, tolerance);
        flip_scene_within("frag-depth-library", format, &[], &settings, tolerance);
        flip_scene_within(
            "frag-depth-library-dynamic",
            format,
            &[],
            &settings,
            tolerance,
        );
        let settings = [("REVZ_MODE", "infinite")];
        let tolerance = Tolerance::flip_plus(format, 1e-3);
        flip_scene_within("frag-depth", format, &[], &settings, tolerance);
    }
}

/// Library-built pipelines take the precise path too: the pre-rasterization library's vertex
/// shader and push-constant layout locate the projection, and the linked pipeline uses it.
/// Complementary Z stores 1 - D (to a few float32 steps of the rewritten projection); infinite
/// mode n/w = 1 - (1 - n/f) D, within n/f = 1e-3 of 1 - D for this camera. The rewritten
/// projection rounds D differently on the cubes' intersection lines: the `overlap` scene itself
/// (no libraries) differs from native in 1 pixel at x8-d24 in complementary mode, hence 2
/// pixels here; D16's coarse grid (1.5e-5) moves 15, so it is left out (`precise.rs` checks D16
/// at interior pixels).
#[test]
fn precise_modes_with_pipeline_libraries() {
    for format in DEPTH_FORMATS.into_iter().filter(|&format| format != "d16") {
        let lines = |extra| Tolerance {
            color_pixels: 2,
            ..Tolerance::flip_plus(format, extra)
        };
        for scene in ["pipeline-library", "pipeline-library-dynamic"] {
            let settings = [("REVZ_MODE", "complementary"), ("REVZ_LOG", "debug")];
            let log = flip_scene_within(scene, format, &[], &settings, lines(4.0 * f32::EPSILON));
            assert!(log.contains("precise path"), "{scene} {format}: {log}");
            let settings = [("REVZ_MODE", "infinite")];
            flip_scene_within(scene, format, &[], &settings, lines(1e-3));
        }
    }
}

/// A depth pre-pass drawn farthest first (`compare-ops-unsorted`), then the EQUAL color pass:
/// in the precise modes every draw of one camera in a recording must store depth on one line,
/// or the EQUAL pass fails wherever the pre-pass drew before the camera's best matrix. Its
/// images, native and through revz, must be those of `compare-ops` (the pre-pass drawn
/// nearest first) bit for bit, with the precise path taken. Session 38's layer, whose camera
/// range improved mid-recording: 29,966 of 65,536 pixels differed in every format, in the
/// first frame (and every frame of a projection that changes each frame).
#[test]
fn a_depth_pre_pass_in_any_order_agrees_with_the_equal_pass_after_it() {
    let harness = Harness::locate();
    let render = |scene: &str, format: &str, mode: Option<&str>| {
        let dir = harness.scratch_dir(&format!(
            "prepass-order-{scene}-{format}-{}",
            mode.unwrap_or("native")
        ));
        let mut command = harness.tester(format, &dir);
        command.args(["--scene", scene]);
        if let Some(mode) = mode {
            harness
                .with_layer(&mut command)
                .env("REVZ_MODE", mode)
                .env("REVZ_LOG", "debug");
        }
        harness.render(command, &dir)
    };
    let mut problems = Vec::new();
    for format in DEPTH_FORMATS {
        let native = render("compare-ops", format, None);
        let unsorted = render("compare-ops-unsorted", format, None);
        assert_eq!(
            differing_pixels(&native.color(), &unsorted.color()),
            0,
            "{format}: the pre-pass order changes the native image"
        );
        for mode in ["complementary", "infinite"] {
            let sorted = render("compare-ops", format, Some(mode));
            let unsorted = render("compare-ops-unsorted", format, Some(mode));
            assert!(
                unsorted.stderr().contains("precise path"),
                "{format} {mode}: no precise path\n{}",
                unsorted.stderr()
            );
            let differing = differing_pixels(&sorted.color(), &unsorted.color());
            if differing != 0 {
                problems.push(format!(
                    "{format} {mode}: {differing} pixels differ from compare-ops' image"
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// `lit-mvp` (issue #14): the vertex shader uses the pushed MVP for lighting too (the clip
/// position's xyz is the view vector; the face normal comes from its screen derivatives), so a
/// layer that rewrites the matrix's depth row changes the shading. Through the layer, with
/// depth readback allowed (`reverse_observable=copies`, so the attachment is reversed), the
/// color image in `flip`, `complementary` and `infinite` must equal the native render exactly:
/// the reversal belongs at the store to `Position`. The precise modes must take the precise
/// path (a layer that fell back to the flip path would pass trivially), every mode's depth must
/// read back reversed (within n/f = 1e-3 of 1 - native: infinite stores n/w), and the native
/// depth must be the standard mapping of the ground truth's w (the nearest face is drawn, not a
/// culled one: back faces are culled in this scene).
#[test]
fn lit_mvp_colors_are_the_native_ones_in_every_mode() {
    let harness = Harness::locate();
    let size = ["--scene", "lit-mvp", "--width", "96", "--height", "64"];
    let native_dir = harness.scratch_dir("lit-mvp-native");
    let mut command = harness.tester("d32", &native_dir);
    command.args(size);
    let native = harness.render(command, &native_dir);
    let truth = native.ground_truth();
    assert!(truth.interior() > truth.width * truth.height / 2);
    let (near, far) = (truth.near, truth.far);
    let comparison = revz_tests::compare_depth(&native.depth(), &truth, |_, w| {
        (far / (far - near) * (1.0 - near / w), 3e-6)
    });
    assert!(
        comparison.holds(),
        "native depth is not the standard mapping of the ground truth: {comparison:?}"
    );
    let (native_color, native_depth) = (native.color(), native.depth());
    let mut problems = Vec::new();
    for mode in ["flip", "complementary", "infinite"] {
        let dir = harness.scratch_dir(&format!("lit-mvp-{mode}"));
        let mut command = harness.tester("d32", &dir);
        command.args(size);
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", mode)
            .env("REVZ_REVERSE_OBSERVABLE", "copies")
            .env("REVZ_COPY_VALUES", "stored")
            .env("REVZ_LOG", "debug");
        let layered = harness.render(command, &dir);
        let log = layered.stderr();
        assert!(log.contains("): reversed"), "{mode}: not reversed\n{log}");
        if mode != "flip" {
            assert!(
                log.contains("precise path"),
                "{mode}: no precise path\n{log}"
            );
        }
        let worst = native_depth
            .iter()
            .zip(layered.depth())
            .zip(&truth.w)
            .filter(|(_, w)| w.is_finite())
            .map(|((n, l), _)| ((1.0 - f64::from(*n)) - f64::from(l)).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1.1e-3, "{mode}: depth is not reversed: {worst:e}");
        let differing = differing_pixels(&native_color, &layered.color());
        eprintln!("lit-mvp {mode}: {differing} color pixels differ from the native render");
        if differing != 0 {
            problems.push(format!(
                "{mode}: {differing} of {} color pixels differ from the native render",
                truth.width * truth.height
            ));
        }
    }
    assert!(problems.is_empty(), "lit-mvp:\n  {}", problems.join("\n  "));
}

/// A depth-read scene rendered with the layer in `mode` (`REVZ_LOG=info`, its depth profile
/// written), under synchronization validation for `frames` frames: the render and the profile.
fn layered_reads(
    harness: &Harness,
    scene: &str,
    format: &str,
    mode: &str,
    frames: &str,
) -> (revz_tests::Render, serde_json::Value) {
    layered_reads_on(harness, scene, format, mode, frames, false)
}

/// [`layered_reads`], on [`Harness::newer_lavapipe`] where `newer` (for the scenes that need
/// what Mesa 22.3's lavapipe lacks).
fn layered_reads_on(
    harness: &Harness,
    scene: &str,
    format: &str,
    mode: &str,
    frames: &str,
    newer: bool,
) -> (revz_tests::Render, serde_json::Value) {
    let name = format!("{scene}-{format}-{mode}");
    let dir = harness.scratch_dir(&name);
    let report = dir.join("profile.json");
    let mut command = harness.tester(format, &dir);
    command.args(["--scene", scene, "--sync-validation", "--frames", frames]);
    if newer {
        harness.on_newer_lavapipe(&mut command);
    }
    harness
        .with_layer(&mut command)
        .env("REVZ_MODE", mode)
        .env("REVZ_LOG", "info")
        .env("REVZ_REPORT", &report);
    let render = harness.render(command, &dir);
    let profile = serde_json::from_str(&std::fs::read_to_string(&report).expect("the profile"))
        .expect("a JSON profile");
    (render, profile)
}

/// The colors of a depth-read scene against the native render of the same format, as
/// `depth_reads_sample_standard_depth_through_the_twin` allows them: at most 2 pixels (D16:
/// its flip tolerance) off by more than 1 level, and at most 200 differing. Where the precise
/// modes promote a UNORM format, shaders still read the application's format (the read twin
/// is UNORM; an input attachment's reads are converted in the shader), so the reference is
/// that format's render too (before session 35 it was native D32's, as the twin was float32).
/// Whether the precise modes promote `format` as D16 (its twin then holds D16 values rounded
/// from revz's float32 depth).
fn promoted_d16(format: &str, mode: &str) -> bool {
    format == "d16" && mode != "flip"
}

/// Interior pixels whose D16 depth read back is the scene's f64 depth (standard [0, 1]
/// depth, `far / (far - near) * (1 - near / w)`) rounded to D16.
fn rounds_the_truth(depth: &[f32], truth: &revz_tests::GroundTruth) -> usize {
    let (near, far) = (truth.near, truth.far);
    depth
        .iter()
        .zip(&truth.w)
        .filter(|(_, w)| w.is_finite())
        .filter(|(&d, &w)| {
            let exact = far / (far - near) * (1.0 - near / w);
            (f64::from(d) * 65535.0).round() == (exact * 65535.0).round()
        })
        .count()
}

/// The reference of a scene whose shaders read depth as float32 where the precise modes
/// promote a UNORM format (input attachments, converted in the reading shader; multisampled
/// images, whose twin is `R32_SFLOAT`): the native D32 render there, else the native render of
/// the same format (`own`). Their reads are not rounded to the application's UNORM format
/// (docs/limits.md).
fn float_read_reference<'a>(
    format: &str,
    mode: &str,
    own: &'a image::RgbaImage,
    native_d32: &'a image::RgbaImage,
) -> &'a image::RgbaImage {
    let promoted = mode != "flip" && ["d16", "x8-d24", "d24-s8"].contains(&format);
    if promoted {
        native_d32
    } else {
        own
    }
}

///
/// A promoted D16 image's twin holds its float32 depth rounded to D16, which differs from
/// lavapipe's own D16 rasterization by one unit at about 1% of `depth-reads`' pixels (571 of
/// 56,184 covered; revz's value is the f64 truth rounded at 545 of them, lavapipe's at 26),
/// and one D16 unit near the far plane moves a fade by several levels: there 64 pixels may be
/// more than 1 level off (measured 47 in `depth-reads`, 15 in `depth-mips`).
fn read_color_problems(
    name: &str,
    (format, mode): (&str, &str),
    reference: &image::RgbaImage,
    color: &image::RgbaImage,
) -> Vec<String> {
    let mut problems = Vec::new();
    let loose = pixels_off_by_more_than(reference, color, 1);
    let bound = if promoted_d16(format, mode) {
        64
    } else if format == "d16" {
        flip_color_tolerance(format)
    } else {
        2
    };
    eprintln!(
        "{name}: {loose} pixels off by more than 1 level, {} differing",
        differing_pixels(reference, color)
    );
    if loose > bound {
        problems.push(format!(
            "{name}: {loose} pixels differ by more than 1 level (bound {bound})"
        ));
    }
    let differing = differing_pixels(reference, color);
    if differing > 200 {
        problems.push(format!("{name}: {differing} pixels differ"));
    }
    problems
}

/// `deferred-depth` and `deferred-depth-tested`: the main depth, written in subpass 0 of a
/// render pass, is read as an input attachment (`subpassLoad`, the attachment in
/// `DEPTH_STENCIL_READ_ONLY_OPTIMAL`, its depth aspect named with
/// `VkRenderPassInputAttachmentAspectCreateInfo`) by the fragment shader of subpass 1, which
/// shades a band of the image with the depth's view distance; subpass 1 has no depth
/// attachment (`deferred-depth`), or keeps the same attachment read-only and draws its band
/// at a fixed depth with GREATER (`deferred-depth-tested`); both again with every pipeline
/// linked from `VK_EXT_graphics_pipeline_library` libraries (`-library`: the fragment shader
/// library's variants convert the reads, and the links' variants link them; before session 25
/// the libraries' reads went unconverted, 16,384 pixels of the band wrong in `flip`); and with
/// subpass 0 drawn from two secondaries, one without its framebuffer
/// (`deferred-depth-secondaries`: in `infinite` it learns from the render pass that the image
/// stores complementary depth; before session 25 it assumed `n / w`: 17,178 pixels wrong in D32). In
/// every depth format and mode,
/// with zero validation messages (synchronization validation included), the colors are the
/// native render's: the layer hands the shader standard depth (converting what it reads
/// where the image is reversed) and reverses the band's fixed depth and compare op with the
/// attachment. The profile says the image is reversed in every mode (in `infinite` it stores
/// complementary depth, which the shader undoes without the camera's n / f).
///
/// The reference, allowances and bounds are those of
/// `depth_reads_sample_standard_depth_through_the_twin`: the native render of the same
/// format, or the native D32 render where the precise modes promote a UNORM format; channels 1
/// level off allowed (the depth converted back, in the shading), and per format a few pixels
/// more than that.
#[test]
fn deferred_depth_reads_standard_depth_through_input_attachments() {
    let harness = Harness::locate();
    let frames = "2";
    let mut problems = Vec::new();
    for scene in [
        "deferred-depth",
        "deferred-depth-tested",
        "deferred-depth-library",
        "deferred-depth-tested-library",
        "deferred-depth-secondaries",
    ] {
        let native = |format: &str| {
            let dir = harness.scratch_dir(&format!("{scene}-{format}-native"));
            let mut command = harness.tester(format, &dir);
            command.args(["--scene", scene, "--sync-validation", "--frames", frames]);
            let render = harness.render(command, &dir);
            // INPUT_ATTACHMENT usage on the main depth image.
            let usage = render.json()["recorded"]["depth_images"][0]["usage"]
                .as_u64()
                .expect("the depth image's usage");
            assert_ne!(usage & 0x80, 0, "{scene} {format}: usage {usage:#x}");
            render.color()
        };
        let native_d32 = native("d32");
        for format in DEPTH_FORMATS {
            let own = native(format);
            for mode in ["flip", "complementary", "infinite"] {
                let name = format!("{scene}-{format}-{mode}");
                let (render, profile) = layered_reads(&harness, scene, format, mode, frames);
                problems.extend(read_color_problems(
                    &name,
                    (format, mode),
                    float_read_reference(format, mode, &own, &native_d32),
                    &render.color(),
                ));
                let image = &profile["images"][0];
                if image["depth"] != "reversed" {
                    problems.push(format!("{name}: not reversed: {image}"));
                }
                if mode == "infinite" && !render.stderr().contains("stores complementary depth") {
                    problems.push(format!("{name}: not stored complementary"));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// `deferred-depth-local-read`, `deferred-depth-local-read-indexed` and
/// `deferred-depth-local-read-tested`: `deferred-depth` and `deferred-depth-tested` in one
/// `vkCmdBeginRendering` (`VK_KHR_dynamic_rendering_local_read`): the main depth, written by
/// the overlap objects, is read back in the same rendering as an input attachment (the
/// attachment kept, in `RENDERING_LOCAL_READ_KHR` throughout, after a by-region barrier
/// inside the rendering), through the default mapping (an input attachment variable without
/// `InputAttachmentIndex`) or, in `-indexed`, the explicit one (index 0 in every pipeline and
/// set with `vkCmdSetRenderingInputAttachmentIndicesKHR`); `-tested` tests its band against
/// the attachment it reads (GREATER at a fixed depth). On the newer lavapipe (Mesa 22.3's lacks
/// the extension: skipped without it), in every depth format:
/// - natively, each renders its render pass twin's image to the pixel (colors and depth);
/// - the installed validation layer (1.3.239) predates the extension, so the tester leaves it
///   out and `render.json` says why: the renders are not validated (where a newer layer runs,
///   it must count no message);
/// - through revz in every mode, the colors are the native render's (the references and
///   bounds of [`deferred_depth_reads_standard_depth_through_input_attachments`]), and the
///   profile says the image is reversed (stored complementary in `infinite`).
///
/// Before the layer learnt these reads (when this test was written), every mode and format
/// shaded the band from the reversed values: the whole band wrong (16,384 pixels) in the first
/// two, the 7,032 surface pixels the tested band shades in `-tested` (its compare op and fixed
/// depth were reversed: the background was left alone); the profile was right.
#[test]
fn local_read_depth_reads_standard_depth_through_input_attachments() {
    let harness = Harness::locate();
    if harness.newer_lavapipe().is_none() {
        eprintln!(
            "skipped: no newer lavapipe in target/lavapipe-backports (`cargo xtask setup`), \
             and Mesa 22.3's lacks VK_KHR_dynamic_rendering_local_read"
        );
        return;
    }
    let frames = "2";
    let mut problems = Vec::new();
    for (scene, twin) in [
        ("deferred-depth-local-read", "deferred-depth"),
        ("deferred-depth-local-read-indexed", "deferred-depth"),
        ("deferred-depth-local-read-tested", "deferred-depth-tested"),
    ] {
        let native = |scene: &str, format: &str| {
            // Its own directory: the render pass twins render in other tests at the same time.
            let dir = harness.scratch_dir(&format!("local-read-{scene}-{format}-native"));
            let mut command = harness.tester(format, &dir);
            command.args(["--scene", scene, "--sync-validation", "--frames", frames]);
            harness.on_newer_lavapipe(&mut command);
            harness.render(command, &dir)
        };
        let local_read = |format: &str| {
            let render = native(scene, format);
            let json = render.json();
            match json["validation_skipped"].as_str() {
                // A validation layer that knows the extension ran, and said nothing.
                None => assert_eq!(json["validation_messages"], 0, "{scene} {format}"),
                Some(why) => assert!(
                    why.contains("predates VK_KHR_dynamic_rendering_local_read"),
                    "{scene} {format}: {why}"
                ),
            }
            let features = json["features"].to_string();
            assert!(
                features.contains("dynamicRenderingLocalRead"),
                "{scene} {format}: {features}"
            );
            // INPUT_ATTACHMENT usage on the main depth image.
            let usage = json["recorded"]["depth_images"][0]["usage"]
                .as_u64()
                .expect("the depth image's usage");
            assert_ne!(usage & 0x80, 0, "{scene} {format}: usage {usage:#x}");
            render
        };
        let native_d32 = local_read("d32").color();
        for format in DEPTH_FORMATS {
            let own = local_read(format);
            let theirs = native(twin, format);
            let differing = differing_pixels(&theirs.color(), &own.color());
            let depths = differing_depths(&theirs.depth(), &own.depth());
            if differing != 0 || depths != 0 {
                problems.push(format!(
                    "{scene}-{format}-native: {differing} pixels and {depths} depths differ \
                     from {twin}'s"
                ));
            }
            let own = own.color();
            for mode in ["flip", "complementary", "infinite"] {
                let name = format!("{scene}-{format}-{mode}");
                let (render, profile) =
                    layered_reads_on(&harness, scene, format, mode, frames, true);
                problems.extend(read_color_problems(
                    &name,
                    (format, mode),
                    float_read_reference(format, mode, &own, &native_d32),
                    &render.color(),
                ));
                let image = &profile["images"][0];
                if image["depth"] != "reversed" {
                    problems.push(format!("{name}: not reversed: {image}"));
                }
                if mode == "infinite" && !render.stderr().contains("stores complementary depth") {
                    problems.push(format!("{name}: not stored complementary"));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// `depth-reads-msaa`: the overlap scene drawn at 4x MSAA into a depth image kept for shaders
/// (SAMPLED usage, not resolved), which a post pass reads per sample
/// (`texelFetch(sampler2DMS(..), pixel, s)` for each of the four samples) to shade the bottom
/// 45% of the image from the nearest and the farthest sample's view distance. In every depth
/// format and mode, with zero validation messages (synchronization validation included), the
/// colors are the native render's, and the profile says the 4x image is reversed and read
/// through its twin (refreshed per sample: a copy through a buffer carries no samples).
/// Meaningful: with `reverse_observable = all` (the raw reversed values handed to shaders) the
/// whole band is wrong.
///
/// The reference, allowances and bounds are those of
/// `depth_reads_sample_standard_depth_through_the_twin`: the native render of the same
/// format, or the native D32 render where the precise modes promote a UNORM format; channels 1
/// level off allowed (the depth converted back, in the shading), and per format a few pixels
/// more than that.
#[test]
fn multisampled_depth_reads_standard_depth_per_sample() {
    let harness = Harness::locate();
    let scene = "depth-reads-msaa";
    let frames = "2";
    let mut problems = Vec::new();
    let native = |format: &str| {
        let dir = harness.scratch_dir(&format!("{scene}-{format}-native"));
        let mut command = harness.tester(format, &dir);
        command.args(["--scene", scene, "--sync-validation", "--frames", frames]);
        let render = harness.render(command, &dir);
        let json = render.json();
        assert_eq!(json["multisample"]["samples"], 4, "{format}: {json}");
        assert_eq!(
            json["multisample"]["depth_resolve"], "NONE",
            "{format}: {json}"
        );
        // SAMPLED usage on the 4x depth image, which is not transient.
        let images = json["recorded"]["depth_images"]
            .as_array()
            .expect("the depth images");
        let multisampled = images
            .iter()
            .find(|image| image["role"] == "multisampled")
            .expect("the multisampled depth image");
        let usage = multisampled["usage"].as_u64().expect("its usage");
        assert_eq!(usage & 0xC4, 0x04, "{format}: usage {usage:#x}");
        render.color()
    };
    let native_d32 = native("d32");
    for format in DEPTH_FORMATS {
        let own = native(format);
        for mode in ["flip", "complementary", "infinite"] {
            let name = format!("{scene}-{format}-{mode}");
            let (render, profile) = layered_reads(&harness, scene, format, mode, frames);
            problems.extend(read_color_problems(
                &name,
                (format, mode),
                float_read_reference(format, mode, &own, &native_d32),
                &render.color(),
            ));
            let Some(image) = profile["images"]
                .as_array()
                .and_then(|images| images.iter().find(|image| image["samples"] == 4))
            else {
                problems.push(format!(
                    "{name}: no 4-sample image in the profile: {profile}"
                ));
                continue;
            };
            if image["depth"] != "reversed" || image["read_twin"] != true {
                problems.push(format!("{name}: not reversed with a read twin: {image}"));
            }
        }
    }
    // The raw reversed values, handed to the shader, shade the whole band wrong.
    let dir = harness.scratch_dir(&format!("{scene}-d32-complementary-observable"));
    let mut command = harness.tester("d32", &dir);
    command.args(["--scene", scene, "--frames", frames]);
    harness
        .with_layer(&mut command)
        .env("REVZ_MODE", "complementary")
        .env("REVZ_REVERSE_OBSERVABLE", "all");
    let raw = pixels_off_by_more_than(&native_d32, &harness.render(command, &dir).color(), 16);
    if raw < 20_000 {
        problems.push(format!(
            "reverse_observable = all: only {raw} pixels differ by more than 16 levels"
        ));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// `depth-mips` and `depth-layers` (issue #39): a depth image of three mip levels (level 0
/// rendered, levels 1 and 2 blitted from the level above, each level made readable by a
/// barrier of its own) and one of two array layers (each rendered through a view of its
/// layer), sampled by a post pass that shades bands from levels 1 and 2, or from layers 0
/// and 1. With the layer, in every reversing mode and depth format: the image is reversed and
/// read through its twin (refreshed per level: three refreshes a frame for the mip chain, one
/// for both layers), zero validation messages (synchronization validation included), and the
/// colors are the native render's of the same format (the promoted formats' twins are UNORM),
/// within `depth-reads`' bounds.
///
/// `depth-layers-stepwise` renders layer 1 twice, each time followed by a barrier of both
/// layers: the second refresh converts layer 1 alone (session 25: a refresh covers only what
/// the recording wrote since it last refreshed), so its frames refresh three layers' bytes,
/// where `depth-layers` refreshes two (and the colors are still the native render's: a refresh
/// that skipped layer 1 would shade its band from the first render).
#[test]
fn depth_mips_and_layers_sample_standard_depth_through_the_twin() {
    let harness = Harness::locate();
    let frames = "2";
    let mut problems = Vec::new();
    // Bytes refreshed over the frames of `depth-layers`, per format and mode.
    let mut layers_bytes = std::collections::HashMap::new();
    for (scene, refreshes_per_frame) in [
        ("depth-mips", 3),
        ("depth-layers", 1),
        ("depth-layers-stepwise", 2),
    ] {
        let native = |format: &str| {
            let dir = harness.scratch_dir(&format!("{scene}-{format}-native"));
            let mut command = harness.tester(format, &dir);
            command.args(["--scene", scene, "--sync-validation", "--frames", frames]);
            harness.render(command, &dir).color()
        };
        for format in DEPTH_FORMATS {
            let own = native(format);
            for mode in ["flip", "complementary", "infinite"] {
                let name = format!("{scene}-{format}-{mode}");
                let (render, profile) = layered_reads(&harness, scene, format, mode, frames);
                if !render.stderr().contains("shaders read its twin") {
                    problems.push(format!("{name}: no read twin in the log"));
                }
                problems.extend(read_color_problems(
                    &name,
                    (format, mode),
                    &own,
                    &render.color(),
                ));
                let image = &profile["images"][0];
                if image["depth"] != "reversed" || image["read_twin"] != true {
                    problems.push(format!("{name}: not reversed with a read twin: {image}"));
                }
                let expected = refreshes_per_frame * frames.parse::<u64>().expect("frames");
                if image["refreshes_recorded"].as_u64() != Some(expected) {
                    problems.push(format!(
                        "{name}: {expected} refreshes expected ({refreshes_per_frame} a frame): \
                         {image}"
                    ));
                }
                let bytes = image["bytes_refreshed"].as_u64().unwrap_or(0);
                match scene {
                    "depth-layers" => {
                        layers_bytes.insert((format, mode), bytes);
                    }
                    "depth-layers-stepwise" => {
                        let two_layers = layers_bytes.get(&(format, mode)).copied();
                        if two_layers.map(|two| two * 3 / 2) != Some(bytes) {
                            problems.push(format!(
                                "{name}: {bytes} bytes refreshed, expected three layers' \
                                 ({two_layers:?} for two)"
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

/// `multiview` and `multiview-dynamic` (`VK_KHR_multiview`): the overlap objects drawn once
/// each into both views of a render pass (or rendering) with view mask 0b11, a 2-layer color
/// and depth image, the views' view-projections in a uniform buffer indexed by
/// `gl_ViewIndex`, then `depth-layers`' post pass shading a band from each layer's depth. With
/// the layer, in every reversing mode and depth format: zero validation messages
/// (synchronization validation included), the depth image reversed with a read twin refreshed
/// once a frame over both layers (twice one layer's bytes), the colors the native render's of
/// the same format within `depth-reads`' bounds (the second band is the second view's depth),
/// and in `complementary` and `infinite` every draw of the multiview pipeline precise (its
/// projection is in a uniform buffer: the derived route). Each view's layer is read back
/// (view 1's into `view1/`, with the ground truth of its own camera) and checked alike
/// ([`view_problems`]): its colors the same view's of the native render within those bounds,
/// its depth read back the native one within the flip tolerance (where the view's ground truth
/// sees one object). `tests/tests/precise.rs::multiview_every_view_against_its_own_camera`
/// checks each view's depth against its ground truth.
#[test]
fn multiview_passes_reverse_every_view() {
    let harness = Harness::locate();
    let frames = "2";
    let mut problems = Vec::new();
    for scene in ["multiview", "multiview-dynamic"] {
        for format in DEPTH_FORMATS {
            let native_dir = harness.scratch_dir(&format!("{scene}-{format}-native"));
            let mut command = harness.tester(format, &native_dir);
            command.args(["--scene", scene, "--sync-validation", "--frames", frames]);
            let native = harness.render(command, &native_dir);
            let native_views = native.views();
            assert_eq!(native_views.len(), 2, "{scene}: two views read back");
            let truth = native.ground_truth();
            for mode in ["flip", "complementary", "infinite"] {
                let name = format!("{scene}-{format}-{mode}");
                let (render, profile) = layered_reads(&harness, scene, format, mode, frames);
                for (view, (own, layered)) in native_views.iter().zip(render.views()).enumerate() {
                    problems.extend(view_problems(
                        &format!("{name} view {view}"),
                        (format, mode),
                        own,
                        &layered,
                    ));
                }
                let image = &profile["images"][0];
                if image["depth"] != "reversed" || image["read_twin"] != true {
                    problems.push(format!("{name}: not reversed with a read twin: {image}"));
                }
                let refreshes = image["refreshes_recorded"].as_u64();
                if refreshes != Some(frames.parse().expect("frames")) {
                    problems.push(format!("{name}: one refresh a frame expected: {image}"));
                }
                // Both layers, every frame: twice the bytes of one layer of the format the
                // twin holds.
                let bytes = image["bytes_refreshed"].as_u64().unwrap_or(0);
                let texels = (truth.width * truth.height) as u64;
                if bytes % (2 * 2 * texels) != 0 || bytes == 0 {
                    problems.push(format!(
                        "{name}: {bytes} bytes refreshed, not both layers of {texels} texels \
                         in each of 2 frames"
                    ));
                }
                if mode != "flip" {
                    for pipeline in profile["pipelines"].as_array().into_iter().flatten() {
                        let draws = &pipeline["draws"];
                        let drawn = ["native", "flip", "precise"]
                            .map(|k| draws[k].as_u64().unwrap_or(0))
                            .iter()
                            .sum::<u64>();
                        if pipeline["path"] != "precise" || draws["precise"].as_u64() != Some(drawn)
                        {
                            problems.push(format!("{name}: a pipeline not precise: {pipeline}"));
                        }
                    }
                    let reasons = &profile["totals"]["flip_reasons"];
                    if reasons.as_array().is_some_and(|r| !r.is_empty()) {
                        problems.push(format!("{name}: flip reasons {reasons}"));
                    }
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// What is wrong with one view of a multiview render through revz (`layered`, with the
/// default policy: copies read back standard depth) against the same view of the native
/// render (`native`): its colors beyond [`read_color_problems`]' bounds, or its depth read
/// back off the native depth by more than the flip tolerance (at least 1e-3) where the view's
/// ground truth sees one object.
fn view_problems(
    name: &str,
    (format, mode): (&str, &str),
    native: &revz_tests::Render,
    layered: &revz_tests::Render,
) -> Vec<String> {
    let mut problems = read_color_problems(name, (format, mode), &native.color(), &layered.color());
    let truth = native.ground_truth();
    let worst = native
        .depth()
        .iter()
        .zip(&layered.depth())
        .zip(&truth.w)
        .filter(|(_, w)| w.is_finite())
        .map(|((n, l), _)| (n - l).abs())
        .fold(0.0f32, f32::max);
    let bound = revz_tests::flip_tolerance(format).max(1e-3);
    eprintln!("{name}: depth at most {worst:e} from the native render's");
    if worst > bound {
        problems.push(format!(
            "{name}: the depth read back is {worst:e} from the native render's (bound {bound:e})"
        ));
    }
    problems
}

/// A rendering suspended in one primary command buffer and resumed in the next of the same
/// batch (`dynamic-rendering-suspended-across`) reverses as one rendering: from its second
/// frame on (each recording's draws get the best camera line the device knows, which in the
/// first frame is the one seen in that recording: one float32 step apart at some pixels), its
/// colors and depth are `dynamic-rendering`'s bit for bit in the precise modes, with no
/// validation message (synchronization validation included).
#[test]
fn a_rendering_resumed_in_another_command_buffer_reverses_as_one() {
    let harness = Harness::locate();
    for mode in ["complementary", "infinite"] {
        let render = |scene: &str| {
            let dir = harness.scratch_dir(&format!("resumed-{scene}-{mode}"));
            let mut command = harness.tester("d32", &dir);
            command.args(["--scene", scene, "--sync-validation", "--frames", "2"]);
            harness.with_layer(&mut command).env("REVZ_MODE", mode);
            harness.render(command, &dir)
        };
        let (one, resumed) = (
            render("dynamic-rendering"),
            render("dynamic-rendering-suspended-across"),
        );
        assert!(one.color() == resumed.color(), "{mode}: colors differ");
        let (a, b) = (one.depth(), resumed.depth());
        let differing = a
            .iter()
            .zip(&b)
            .filter(|(x, y)| x.to_bits() != y.to_bits())
            .count();
        assert_eq!(differing, 0, "{mode}: depth differs at {differing} pixels");
    }
}
