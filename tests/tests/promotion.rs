//! End-to-end tests of depth format promotion (issue #15), on lavapipe under the validation
//! layer: revz creates a D16_UNORM or X8_D24_UNORM_PACK32 depth image as D32_SFLOAT, and a
//! D24_UNORM_S8_UINT one as D32_SFLOAT_S8_UINT (`promote_depth_formats`, by default in
//! `complementary` and `infinite`), where the image has optimal tiling and no host image copy
//! usage (copies in command buffers convert between the formats: `tests/tests/copies.rs`).
//! Every render here runs with `--no-depth-readback`, so that only promotion differs from the
//! reference renders: the tester then creates its
//! depth images (the main one, and the 4x transient one of `msaa-resolve`) as attachments only,
//! without TRANSFER_SRC or TRANSFER_DST (none of these scenes clears an image with
//! `vkCmdClearDepthStencilImage`), and only color is read back. The layer's log (`REVZ_LOG=info`,
//! on the tester's stderr) says once per depth image `(FORMAT, WxH): reversed, promoted to
//! D32_SFLOAT (N more bytes)` (or `D32_SFLOAT_S8_UINT`); without promotion the line ends in
//! `): reversed`.
//!
//! - `promoted_stencil`, `promoted_decal_bias`, `promoted_depth_bias`,
//!   `promoted_msaa_resolve`, `promoted_secondary`, `promoted_dynamic_rendering`,
//!   `promoted_pipeline_library` (and their dynamic-rendering twins): the scene in every format revz promotes that it supports
//!   (`stencil`: D24_S8 only; the others D16, X8_D24 and D24_S8), in `complementary` and
//!   `infinite`, with the default setting: zero validation messages (the layer changes the
//!   image's format, so its views, render passes, framebuffers, dynamic rendering and pipeline
//!   formats must follow), every depth image of the scene's format logged as reversed and
//!   promoted to its float format, and the colors those of the native render (no layer, same
//!   format, same arguments) up to [`precise_color_differences`]: a pixel may differ where the
//!   native render in the float format shows what the promoted one shows (the source format's
//!   ties, which float depth resolves: D16's grid of 1.5e-5 moves up to 45 pixels of these
//!   scenes between D16 and D32 natively), and at most [`PRECISE_LINE_PIXELS`] other pixels (the
//!   precise path's intersection lines); and bit-identical to the same mode's render in the
//!   float format (D32, D32_S8): promotion makes the UNORM format render exactly as the float
//!   one. A promotion that lost the stencil, a depth bias that no longer holds the decals, or a
//!   resolve into the wrong format differs from both.
//! - `never_promotes_nothing_and_renders_as_before`: `REVZ_PROMOTE_DEPTH_FORMATS=never` in
//!   `complementary` (`depth-bias` in the three formats, `stencil`, `msaa-resolve` in D16) logs
//!   every depth image as `): reversed` with no promotion, and renders colors bit-identical to
//!   the complementary render with depth readback allowed and `never` too
//!   (`REVZ_REVERSE_OBSERVABLE=copies`: reversed, not promoted).
//! - `flip_does_not_promote_by_default`: in `flip` mode the default setting (`auto`) promotes
//!   nothing: every depth image is logged `): reversed`, and the colors are the native ones
//!   within the flip path's tolerance (`flip_color_tolerance`).
//! - `depth_image_lines_are_parsed`: no GPU; the log parsing the others rely on tells a
//!   promotion to D32_SFLOAT from one to D32_SFLOAT_S8_UINT, and an unpromoted line from both.

use revz_tests::{differing_pixels, flip_color_tolerance, Harness, Render};

/// The formats revz promotes (the tester has no D16_UNORM_S8_UINT): the tester's name, the
/// tester's name of the float format it becomes, and that format's Vulkan name.
const PROMOTIONS: [Promotion; 3] = [
    Promotion {
        format: "d16",
        vk_format: "D16_UNORM",
        float: "d32",
        promoted: "D32_SFLOAT",
    },
    Promotion {
        format: "x8-d24",
        vk_format: "X8_D24_UNORM_PACK32",
        float: "d32",
        promoted: "D32_SFLOAT",
    },
    Promotion {
        format: "d24-s8",
        vk_format: "D24_UNORM_S8_UINT",
        float: "d32-s8",
        promoted: "D32_SFLOAT_S8_UINT",
    },
];

/// One promoted format.
#[derive(Clone, Copy, Debug)]
struct Promotion {
    /// `--depth-format` of the render.
    format: &'static str,
    /// Its Vulkan name, as the layer logs the image.
    vk_format: &'static str,
    /// `--depth-format` of the float format it is promoted to.
    float: &'static str,
    /// That format's Vulkan name, as the layer logs the promotion.
    promoted: &'static str,
}

/// The promoted formats `scene` renders with: the stencil scene needs a stencil aspect.
fn promotions(scene: &str) -> Vec<Promotion> {
    PROMOTIONS
        .into_iter()
        .filter(|p| scene != "stencil" || p.format == "d24-s8")
        .collect()
}

/// The depth images each scene creates in the render's format: the main one, and
/// `msaa-resolve`'s 4x transient attachment.
fn depth_images(scene: &str) -> usize {
    if scene == "msaa-resolve" {
        2
    } else {
        1
    }
}

/// The most pixels a render through the precise path may differ from the native render in
/// its own format beyond what the format explains: `precise_modes_with_pipeline_libraries`
/// (e2e.rs) allows 2, because the rewritten projection rounds D differently on the cubes'
/// intersection lines (`overlap` itself differs in 1 pixel at x8-d24). Measured on lavapipe
/// with native D32 and D32_S8 images (what a promoted image is) in `complementary` and
/// `infinite`: `secondary` 2, `pipeline-library` 1, the other scenes here 0.
const PRECISE_LINE_PIXELS: usize = 2;

/// A tester render of `scene` in `format` without depth readback (so revz may promote the
/// image), with `settings` (environment variables) and the layer when `layer` is set.
fn render(
    harness: &Harness,
    name: &str,
    scene: &str,
    format: &str,
    layer: bool,
    settings: &[(&str, &str)],
) -> Render {
    let dir = harness.scratch_dir(&format!("promotion-{name}"));
    let mut command = harness.tester(format, &dir);
    command.args(["--scene", scene, "--no-depth-readback"]);
    if layer {
        harness.with_layer(&mut command).env("REVZ_LOG", "info");
    }
    command.envs(settings.iter().copied());
    harness.render(command, &dir)
}

/// The layer's line for each depth image it saw created: (format, what follows `): `).
fn depth_image_lines(log: &str) -> Vec<(String, String)> {
    log.lines()
        .filter_map(|line| {
            let rest = &line[line.find("depth image ")?..];
            let open = rest.find(" (")? + 2;
            let close = open + rest[open..].find("): ")?;
            // The creation line names the format and the size: `(D16_UNORM, 256x256)`.
            let (format, _size) = rest[open..close].split_once(", ")?;
            Some((format.to_owned(), rest[close + 3..].to_owned()))
        })
        .collect()
}

/// Why the log does not show every depth image of `vk_format` reversed and promoted to
/// `promoted` (`Some(promoted)`), or reversed and not promoted (`None`); `None` when it does.
fn promotion_problem(
    log: &str,
    vk_format: &str,
    images: usize,
    promoted: Option<&str>,
) -> Option<String> {
    let lines: Vec<String> = depth_image_lines(log)
        .into_iter()
        .filter(|(format, _)| format == vk_format)
        .map(|(_, outcome)| outcome)
        .collect();
    let good = |outcome: &String| match promoted {
        Some(float) => outcome.starts_with(&format!("reversed, promoted to {float} (")),
        None => outcome == "reversed",
    };
    if lines.len() == images && lines.iter().all(good) {
        return None;
    }
    let want = promoted.map_or("reversed".to_owned(), |float| {
        format!("reversed, promoted to {float} (N more bytes)")
    });
    Some(format!(
        "{images} {vk_format} image(s) should be logged `): {want}`; the layer logged {lines:?}"
    ))
}

/// The pixels where `layered` differs from `native` (no layer, the same format) that
/// `float_native` (no layer, the float format revz promotes to) does not explain, i.e. where
/// `layered` differs from both; and how many differ from `native` in all.
fn precise_color_differences(
    native: &image::RgbaImage,
    float_native: &image::RgbaImage,
    layered: &image::RgbaImage,
) -> (Vec<String>, usize) {
    assert_eq!(native.dimensions(), layered.dimensions());
    assert_eq!(float_native.dimensions(), layered.dimensions());
    let width = native.width() as usize;
    let mut differing = 0;
    let unexplained = native
        .pixels()
        .zip(float_native.pixels())
        .zip(layered.pixels())
        .enumerate()
        .filter(|(_, ((n, _), l))| n != l)
        .inspect(|_| differing += 1)
        .filter(|(_, ((_, f), l))| f != l)
        .map(|(at, ((n, f), l))| {
            format!(
                "pixel ({}, {}): {:?} natively, {:?} natively in the float format, {:?} promoted",
                at % width,
                at / width,
                n.0,
                f.0,
                l.0
            )
        })
        .collect();
    (unexplained, differing)
}

/// Renders `scene` in every format revz promotes that it supports, natively and in the float
/// format, then through the layer in `complementary` and `infinite`; checks the log and the
/// colors (module docs).
fn promoted_scene(scene: &str) {
    let harness = Harness::locate();
    let mut problems = Vec::new();
    for p in promotions(scene) {
        let native = render(
            &harness,
            &format!("{scene}-{}-native", p.format),
            scene,
            p.format,
            false,
            &[],
        );
        let float_native = render(
            &harness,
            &format!("{scene}-{}-native-{}", p.format, p.float),
            scene,
            p.float,
            false,
            &[],
        );
        let (native, float_native) = (native.color(), float_native.color());
        for mode in ["complementary", "infinite"] {
            let case = format!("{scene} {} {mode}", p.format);
            // The same mode in the float format: promotion makes the UNORM format render
            // exactly as it.
            let float_layered = render(
                &harness,
                &format!("{scene}-{}-{mode}-{}", p.format, p.float),
                scene,
                p.float,
                true,
                &[("REVZ_MODE", mode)],
            )
            .color();
            let layered = render(
                &harness,
                &format!("{scene}-{}-{mode}", p.format),
                scene,
                p.format,
                true,
                &[("REVZ_MODE", mode)],
            );
            let log = layered.stderr();
            assert_eq!(
                layered.loaded_mode().as_deref(),
                Some(mode),
                "{case}: {log}"
            );
            assert_eq!(layered.json()["depth_readback"], false, "{case}");
            if let Some(problem) =
                promotion_problem(&log, p.vk_format, depth_images(scene), Some(p.promoted))
            {
                problems.push(format!("{case}: {problem}"));
            }
            let as_float = differing_pixels(&float_layered, &layered.color());
            if as_float != 0 {
                problems.push(format!(
                    "{case}: {as_float} color pixels differ from the same mode's render in {}",
                    p.float
                ));
            }
            let (unexplained, differing) =
                precise_color_differences(&native, &float_native, &layered.color());
            eprintln!(
                "{case}: {differing} color pixels differ from the native render, {} of them \
                 not as natively in {}",
                unexplained.len(),
                p.float
            );
            if unexplained.len() > PRECISE_LINE_PIXELS {
                problems.push(format!(
                    "{case}: {} color pixels differ from the native renders in both {} and {} \
                     (at most {PRECISE_LINE_PIXELS}):\n    {}",
                    unexplained.len(),
                    p.format,
                    p.float,
                    unexplained.join("\n    ")
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{scene}:\n  {}", problems.join("\n  "));
}

#[test]
fn promoted_stencil() {
    promoted_scene("stencil");
}

#[test]
fn promoted_decal_bias() {
    promoted_scene("decal-bias");
}

#[test]
fn promoted_depth_bias() {
    promoted_scene("depth-bias");
}

#[test]
fn promoted_msaa_resolve() {
    promoted_scene("msaa-resolve");
}

#[test]
fn promoted_secondary() {
    promoted_scene("secondary");
}

#[test]
fn promoted_dynamic_rendering() {
    promoted_scene("dynamic-rendering");
}

#[test]
fn promoted_dynamic_rendering_suspended() {
    promoted_scene("dynamic-rendering-suspended");
    promoted_scene("dynamic-rendering-suspended-across");
}

/// The secondaries inherit the application's D16 or D24 format, which revz replaces with the
/// promoted one the rendering's view has.
#[test]
fn promoted_dynamic_rendering_secondaries() {
    promoted_scene("dynamic-rendering-secondaries");
}

#[test]
fn promoted_pipeline_library() {
    promoted_scene("pipeline-library");
}

/// The same libraries in a dynamic rendering: the formats revz promotes are named by the
/// fragment output interface library alone.
#[test]
fn promoted_pipeline_library_dynamic() {
    promoted_scene("pipeline-library-dynamic");
}

#[test]
fn never_promotes_nothing_and_renders_as_before() {
    let harness = Harness::locate();
    let cases = [
        ("depth-bias", PROMOTIONS[0]),
        ("depth-bias", PROMOTIONS[1]),
        ("depth-bias", PROMOTIONS[2]),
        ("msaa-resolve", PROMOTIONS[0]),
        ("stencil", PROMOTIONS[2]),
    ];
    let mut problems = Vec::new();
    for (scene, p) in cases {
        let case = format!("{scene} {}", p.format);
        // The reference: reversed (copies may be reversed), depth read back, with `never`
        // too (since copies convert between the formats, transfer usage no longer keeps an
        // image's format: only the setting does). What is compared is the readback's absence:
        // a render without it must show what one with it shows.
        let dir = harness.scratch_dir(&format!("promotion-never-{scene}-{}-before", p.format));
        let mut command = harness.tester(p.format, &dir);
        command.args(["--scene", scene]);
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", "complementary")
            .env("REVZ_REVERSE_OBSERVABLE", "copies")
            .env("REVZ_COPY_VALUES", "stored")
            .env("REVZ_LOG", "info")
            .env("REVZ_PROMOTE_DEPTH_FORMATS", "never");
        let before = harness.render(command, &dir);
        let log = before.stderr();
        assert_eq!(before.json()["depth_readback"], true, "{case}");
        assert_eq!(
            promotion_problem(&log, p.vk_format, depth_images(scene), None),
            None,
            "{case}: the read-back image is reversed and not promoted\n{log}"
        );
        let never = render(
            &harness,
            &format!("never-{scene}-{}", p.format),
            scene,
            p.format,
            true,
            &[
                ("REVZ_MODE", "complementary"),
                ("REVZ_PROMOTE_DEPTH_FORMATS", "never"),
            ],
        );
        let log = never.stderr();
        if let Some(problem) = promotion_problem(&log, p.vk_format, depth_images(scene), None) {
            problems.push(format!("{case}: {problem}"));
        }
        let differing = differing_pixels(&before.color(), &never.color());
        assert_eq!(
            differing, 0,
            "{case}: with never, {differing} color pixels differ from the render before \
             promotion\n{log}"
        );
        // The layer takes the value (one that does not know it warns and keeps its default).
        let warnings: Vec<&str> = log.lines().filter(|l| l.contains("[revz WARN]")).collect();
        if !warnings.is_empty() {
            problems.push(format!(
                "{case}: REVZ_PROMOTE_DEPTH_FORMATS=never was not taken: {}",
                warnings.join("\n")
            ));
        }
    }
    assert!(problems.is_empty(), "never:\n  {}", problems.join("\n  "));
}

#[test]
fn flip_does_not_promote_by_default() {
    let harness = Harness::locate();
    for scene in ["depth-bias", "msaa-resolve", "stencil"] {
        for p in promotions(scene) {
            let case = format!("{scene} {}", p.format);
            let native = render(
                &harness,
                &format!("flip-{scene}-{}-native", p.format),
                scene,
                p.format,
                false,
                &[],
            );
            let flipped = render(
                &harness,
                &format!("flip-{scene}-{}", p.format),
                scene,
                p.format,
                true,
                &[("REVZ_MODE", "flip")],
            );
            let log = flipped.stderr();
            assert_eq!(
                flipped.loaded_mode().as_deref(),
                Some("flip"),
                "{case}: {log}"
            );
            assert_eq!(
                promotion_problem(&log, p.vk_format, depth_images(scene), None),
                None,
                "{case}: flip mode promoted\n{log}"
            );
            let differing = differing_pixels(&native.color(), &flipped.color());
            assert!(
                differing <= flip_color_tolerance(p.format),
                "{case}: {differing} color pixels differ from the native render"
            );
        }
    }
}

#[test]
fn depth_image_lines_are_parsed() {
    let log = "\
[revz INFO] revz 0.1.0 loaded as VK_LAYER_REVZ_reverse_z: mode complementary; far_clip=remove
[revz INFO] depth image 0x5 (D16_UNORM, 256x256): reversed, promoted to D32_SFLOAT (262144 more bytes)
[revz INFO] depth image 0xb (D16_UNORM, 256x256): reversed
[revz INFO] depth image 0xb (D16_UNORM): native from now on, because it is resolved into native
[revz INFO] depth image 0xc (D32_SFLOAT, 512x512): native, because shaders read it (SAMPLED)
";
    let lines = depth_image_lines(log);
    assert_eq!(lines.len(), 3, "{lines:?}");
    assert_eq!(lines[0].0, "D16_UNORM");
    let one =
        "depth image 0x5 (D16_UNORM, 96x64): reversed, promoted to D32_SFLOAT (12 more bytes)";
    assert_eq!(
        promotion_problem(one, "D16_UNORM", 1, Some("D32_SFLOAT")),
        None
    );
    assert!(promotion_problem(one, "D16_UNORM", 1, None).is_some());
    assert!(promotion_problem(log, "D16_UNORM", 2, Some("D32_SFLOAT")).is_some());
    assert!(promotion_problem(log, "D16_UNORM", 2, None).is_some());
    assert_eq!(
        promotion_problem(log, "D32_SFLOAT", 1, None),
        Some(
            "1 D32_SFLOAT image(s) should be logged `): reversed`; the layer logged \
             [\"native, because shaders read it (SAMPLED)\"]"
                .to_owned()
        )
    );
    // D32_SFLOAT is not D32_SFLOAT_S8_UINT.
    let s8 = "depth image 0x5 (D24_UNORM_S8_UINT, 96x64): reversed, promoted to D32_SFLOAT_S8_UINT (1 more bytes)";
    assert_eq!(
        promotion_problem(s8, "D24_UNORM_S8_UINT", 1, Some("D32_SFLOAT_S8_UINT")),
        None
    );
    assert!(promotion_problem(s8, "D24_UNORM_S8_UINT", 1, Some("D32_SFLOAT")).is_some());
}
