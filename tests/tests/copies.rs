//! Copies of reversed depth images hand back standard depth (issue #21, `layer/src/depth_copy`),
//! on lavapipe under the validation layer with synchronization validation on.
//!
//! - Under the default policy (`reverse_observable = copies`, `copy_values = standard`) the
//!   tester's read-back depth image is reversed (and with every other depth image of the scene
//!   promoted to float32 where the mode promotes: D16 and D24 in `complementary` and
//!   `infinite`), and every scene in every mode and format reads back the depth it has without
//!   revz: within [`converted_tolerance`] of the native
//!   render, colors within [`flip_color_tolerance`]. The hard precision cases (`STRESS`) are
//!   judged against ground truth by the accuracy tests, not against the native render, whose
//!   depth and colors they are built to get wrong; their conversion is still checked exactly.
//! - The conversion is exact: the same render read back with `copy_values = stored` gives the
//!   stored values, and for the flip and complementary maps the standard ones are their
//!   complement, bit for bit (UNORM integers: max - u; float: 1 - v in float32); within one
//!   unit where the image is promoted (D16 and D24 in `complementary` and `infinite`: both are
//!   rounded into the application's UNORM format from float32 storage, issue #40).
//! - Every copy route (`--depth-route`: image to image, to a native image, to an image that
//!   keeps its UNORM format while the first is promoted, a round trip through a buffer into
//!   another reversed image, mirrored blits into a native and into a UNORM image, padded buffer
//!   rows, the `*2` commands, an image with transfer usage only (native: issue #44), a slice of
//!   a 3D image, a blit of a 3D box several slices deep) reads back what the direct copy does:
//!   exactly, but for the
//!   device's blit rounding, infinite mode's round trips, and promoted images read back through
//!   a second image or a buffer (rounded into the UNORM grid twice: within one step).
//!
//! Every render here is two frames (`--frames 2`): infinite mode learns the camera's n / f in
//! the first, and stores the first frame's clears and early draws with the n / f known then
//! (see `docs/copies.md`).

use std::process::Command;

use revz_tests::{
    differing_pixels, flip_color_tolerance, flip_tolerance, pixels_off_by_more_than,
    unexplained_color_differences, Harness, Render,
};

/// The scenes built to defeat standard depth (the accuracy report's): their native render is
/// not the reference.
const STRESS: [&str; 7] = [
    "sloped-plane",
    "mars-patch",
    "tori",
    "plane-stack",
    "deep-range",
    "decal-bias",
    "far-objects",
];

/// The scenes whose colors are shaded from the depth their shaders sample (`depth-reads`:
/// soft particles' fades, a band of view distances).
const SHADED_FROM_DEPTH: [&str; 15] = [
    "depth-reads",
    "deferred-depth",
    "deferred-depth-tested",
    "deferred-depth-library",
    "deferred-depth-tested-library",
    "deferred-depth-secondaries",
    "deferred-depth-local-read",
    "deferred-depth-local-read-indexed",
    "deferred-depth-local-read-tested",
    "depth-reads-msaa",
    "depth-mips",
    "depth-layers",
    "depth-layers-stepwise",
    "multiview",
    "multiview-dynamic",
];

/// Scenes rendered on the newer lavapipe where there is one ([`Harness::newer_lavapipe`]):
/// Mesa 22.3's lacks `VK_KHR_dynamic_rendering_local_read`.
const NEWER_LAVAPIPE: [&str; 3] = [
    "deferred-depth-local-read",
    "deferred-depth-local-read-indexed",
    "deferred-depth-local-read-tested",
];

const REVERSING_MODES: [&str; 3] = ["flip", "complementary", "infinite"];

/// Every scene the tester has.
fn scenes(harness: &Harness) -> Vec<String> {
    let output = revz_tests::clean_command(&harness.tester)
        .arg("scenes")
        .output()
        .expect("start revz-tester");
    assert!(output.status.success(), "revz-tester scenes failed");
    let names: Vec<String> = String::from_utf8_lossy(&output.stdout)
        .lines()
        .map(str::to_owned)
        .collect();
    assert!(names.len() > 30, "too few scenes: {names:?}");
    names
}

/// How far the depth read back through revz may lie from the native render's. The flip path
/// stores the rasterizer's 1 - D ([`flip_tolerance`]); the precise path computes depth from
/// the rewritten matrix, whose float32 rounding differs from the standard one's near depth 1
/// (its relative error there is the native render's own: about 4 ulp of 1 in the vertex
/// transform, plus interpolation), so D24 and D32 get 8 units of 2^-24 (measured on lavapipe:
/// at most 6, `secondary` in D24); D16's grid is coarser than either: 2 steps.
fn converted_tolerance(format: &str, mode: &str) -> f32 {
    match (format, mode) {
        (_, "flip") | ("d16", _) => flip_tolerance(format),
        _ => 8.0 / 16_777_216.0,
    }
}

/// A known inexactness of revz's stored depth, not of the conversion: in infinite mode a
/// rewritten fragment depth stores 1 - d, not the 1 - (1 - n/f) d of every other draw (n / f is
/// known only at draw time; `docs/limits.md`), so the `frag-depth` scenes read back within n / f
/// of the camera (0.1 / 100).
///
/// `depth-range-unrestricted` draws its world with viewport depth [-20, 1.5]: the viewport
/// scales depth, and with it the float32 rounding the precise path's depth differs by, 21.5
/// times.
fn known_limit(scene: &str, mode: &str) -> f32 {
    if mode == "infinite" && scene.starts_with("frag-depth") {
        1e-3
    } else if scene.starts_with("depth-range-unrestricted") && mode != "flip" {
        21.5 * 8.0 / 16_777_216.0
    } else {
        0.0
    }
}

/// The scenes whose device has `VK_EXT_depth_range_unrestricted` enabled: revz promotes no
/// UNORM image there (issue #44: a float format would keep depth outside [0, 1] that the UNORM
/// one clamps), and in infinite mode reverses depth as complementary mode does.
const UNRESTRICTED: [&str; 2] = [
    "depth-range-unrestricted",
    "depth-range-unrestricted-clear-one",
];

/// How many color pixels may differ from the native render in a scene without ground truth.
/// The flip path: [`flip_color_tolerance`]. The precise path computes depth with other float32
/// rounding, so a pixel on an intersection line of two surfaces may resolve the other way: 2
/// (measured on lavapipe: at most 1, `compare-ops` and `viewport-split` in D24 and D32). In
/// D16 surfaces closer than one step of its grid (1.5e-5) tie, and which pairs tie depends on
/// where the values fall between grid steps: the flip path stores the exact complement (the
/// same ties), complementary mode nearly so (measured: at most 2 pixels), infinite mode's
/// n / w is a slightly scaled value (by 1 / (1 - n/f)) and ties other pairs: 48 (measured:
/// 38, `msaa-resolve` with its four samples per pixel; 6 to 15 in the other scenes). Those
/// pixels are ties in the native render too, where draw order decides; their depth is checked
/// within one step like every other pixel.
fn color_tolerance(format: &str, mode: &str) -> usize {
    match (mode, format) {
        ("flip", _) => flip_color_tolerance(format),
        ("infinite" | "complementary", "d16") => 48,
        (_, "d16") => flip_color_tolerance(format),
        _ => 2,
    }
}

/// The tester's render arguments for one case.
fn tester(harness: &Harness, format: &str, dir: &std::path::Path, args: &[&str]) -> Command {
    let mut command = harness.tester(format, dir);
    command
        .args(["--sync-validation", "--frames", "2"])
        .args(args);
    let scene = args
        .iter()
        .position(|&arg| arg == "--scene")
        .and_then(|at| args.get(at + 1));
    if scene.is_some_and(|scene| NEWER_LAVAPIPE.contains(scene)) {
        harness.on_newer_lavapipe(&mut command);
    }
    command
}

/// The native render of `scene`, or `None` where the tester refuses the combination (a
/// scene that needs a feature lavapipe lacks, or a stencil format).
fn native(harness: &Harness, scene: &str, format: &str) -> Option<Render> {
    let dir = harness.scratch_dir(&format!("copies-{scene}-{format}-native"));
    let output = tester(harness, format, &dir, &["--scene", scene])
        .output()
        .expect("start revz-tester");
    if output.status.code() == Some(1) {
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            stderr.contains("revz-tester: error:"),
            "{scene} {format}: {stderr}"
        );
        return None;
    }
    let render = Render { dir, output };
    render.assert_clean();
    Some(render)
}

fn layered(harness: &Harness, scene: &str, format: &str, mode: &str, stored: bool) -> Render {
    let values = if stored { "stored" } else { "standard" };
    let dir = harness.scratch_dir(&format!("copies-{scene}-{format}-{mode}-{values}"));
    let mut command = tester(harness, format, &dir, &["--scene", scene]);
    harness
        .with_layer(&mut command)
        .env("REVZ_MODE", mode)
        .env("REVZ_COPY_VALUES", values)
        .env("REVZ_LOG", "info");
    harness.render(command, &dir)
}

/// The Vulkan name of a UNORM format the precise modes promote (`None` for the float ones).
fn promoted_vk_format(format: &str) -> Option<&'static str> {
    match format {
        "d16" => Some("D16_UNORM"),
        "x8-d24" => Some("X8_D24_UNORM_PACK32"),
        "d24-s8" => Some("D24_UNORM_S8_UINT"),
        _ => None,
    }
}

/// The layer's creation lines of depth images of `vk_format` that were not promoted (each
/// promoted one reads `depth image 0x.. (FORMAT, WxH): reversed, promoted to ...`, or
/// `native, because ...; promoted to ...`), and how many there were in all.
fn unpromoted_images(log: &str, vk_format: &str) -> (Vec<String>, usize) {
    let created: Vec<&str> = log
        .lines()
        .filter(|line| line.contains("depth image ") && line.contains(&format!("({vk_format}, ")))
        .collect();
    let unpromoted = created
        .iter()
        .filter(|line| !line.contains("promoted to D32_SFLOAT"))
        .map(|line| line.to_string())
        .collect();
    (unpromoted, created.len())
}

/// The largest integer of a UNORM format's depth.
fn unorm_max(format: &str) -> Option<f64> {
    match format {
        "d16" => Some(65535.0),
        "x8-d24" | "d24-s8" => Some(16_777_215.0),
        _ => None,
    }
}

/// Standard values are the exact complement of the stored ones (flip and complementary maps),
/// where the image keeps its format. A promoted image (float32 storage) hands over each value
/// rounded into the application's UNORM format: the standard 1 - v and the stored v are each
/// rounded to the nearest integer from float32 (1 - v itself rounded to float32 first), so
/// they are complements within one unit.
fn assert_complement(format: &str, promoted: bool, standard: &[f32], stored: &[f32], what: &str) {
    let units = if promoted { 1.0 } else { 0.0 };
    let wrong = standard
        .iter()
        .zip(stored)
        .filter(|(&d, &v)| match unorm_max(format) {
            Some(max) => {
                let (d, v) = ((f64::from(d) * max).round(), (f64::from(v) * max).round());
                (d - (max - v)).abs() > units
            }
            None => d.to_bits() != (1.0 - v).to_bits(),
        })
        .count();
    assert_eq!(
        wrong, 0,
        "{what}: standard values are not the complement of the stored"
    );
}

/// Every scene, every reversing mode, one format: see the module's first two points.
fn default_policy_hands_back_native_depth(format: &str) {
    let harness = Harness::locate();
    let (mut checked, mut refused) = (0, Vec::new());
    for scene in scenes(&harness) {
        let Some(native) = native(&harness, &scene, format) else {
            refused.push(scene);
            continue;
        };
        let (native_color, native_depth) = (native.color(), native.depth());
        for mode in REVERSING_MODES {
            let what = format!("{scene}, {format}, {mode}");
            let standard = layered(&harness, &scene, format, mode, false);
            let stored = layered(&harness, &scene, format, mode, true);
            let log = standard.stderr();
            assert!(
                !log.contains("is not converted"),
                "{what}: a copy went down unconverted\n{log}"
            );
            // Issue #40: the read-back image (TRANSFER_SRC) and every other depth image of the
            // scene is promoted where the mode promotes.
            if let (Some(_), true) = (
                promoted_vk_format(format),
                UNRESTRICTED.contains(&scene.as_str()),
            ) {
                assert!(
                    !log.contains("promoted to")
                        && (mode == "flip"
                            || log.contains("enabled VK_EXT_depth_range_unrestricted")),
                    "{what}: a UNORM image promoted on a device with unrestricted depth\n{log}"
                );
            } else if let (Some(vk_format), true) = (promoted_vk_format(format), mode != "flip") {
                let (unpromoted, created) = unpromoted_images(&log, vk_format);
                assert!(
                    created > 0 && unpromoted.is_empty(),
                    "{what}: {} of {created} depth images not promoted: {unpromoted:?}",
                    unpromoted.len()
                );
            }
            let (depth, stored_depth) = (standard.depth(), stored.depth());
            let reversed = depth
                .iter()
                .zip(&stored_depth)
                .any(|(a, b)| a.to_bits() != b.to_bits());
            let unrestricted = UNRESTRICTED.contains(&scene.as_str());
            if unrestricted {
                // Every image reversed, in infinite mode as complementary mode reverses
                // (before session 35 UNORM images stayed native there, and a clear of 1 let
                // D32 surfaces beyond the far plane show: 43 pixels).
                assert!(reversed, "{what}: not reversed\n{log}");
                assert_eq!(
                    mode == "infinite",
                    log.contains("infinite mode reverses depth as complementary mode does"),
                    "{what}\n{log}"
                );
            }
            if !reversed {
                // The read-back image is not reversed (the application renders reversed
                // depth itself): nothing may change.
                assert_eq!(depth, native_depth, "{what}: a native image changed\n{log}");
                continue;
            }
            if mode != "infinite" || unrestricted {
                let promoted = log.contains("promoted to D32_SFLOAT");
                assert_complement(format, promoted, &depth, &stored_depth, &what);
            }
            checked += 1;
            if STRESS.contains(&scene.as_str()) {
                continue;
            }
            let tolerance = converted_tolerance(format, mode).max(known_limit(&scene, mode));
            let (worst, at) = depth
                .iter()
                .zip(&native_depth)
                .map(|(a, b)| (a - b).abs())
                .enumerate()
                .fold(
                    (0f32, 0),
                    |(w, at), (i, d)| if d > w { (d, i) } else { (w, at) },
                );
            assert!(
                worst <= tolerance,
                "{what}: depth read back {worst:e} from the native render at pixel {at} \
                 (bound {tolerance:e}): {} vs {}",
                depth[at],
                native_depth[at]
            );
            let color = standard.color();
            if SHADED_FROM_DEPTH.contains(&scene.as_str()) {
                // Colors computed from the depth shaders read: the depth converted back to
                // standard values rounds a level or two of them differently.
                let colors = pixels_off_by_more_than(&native_color, &color, 2);
                assert!(
                    colors <= color_tolerance(format, mode),
                    "{what}: {colors} color pixels differ from the native render by more \
                     than 2 levels"
                );
            } else if native.dir.join("expected-id.u16").exists() {
                // Where the ground truth says which surface is nearest, a differing pixel
                // must show it (a tie the native render resolved with less precision).
                let unexplained =
                    unexplained_color_differences(&native_color, &color, &native.ground_truth());
                // Shaded scenes (shadows) have no flat colors to explain a pixel by: their
                // differences count against the same bound as scenes without ground truth. A
                // silhouette or intersection pixel whose two surfaces are within the depth
                // tolerance at its center is a tie the truth cannot settle either: 2 more of
                // those (measured: 1, `push-partial` in flip mode).
                let interior = unexplained
                    .iter()
                    .filter(|u| u.contains("(interior)"))
                    .count();
                assert!(
                    interior <= color_tolerance(format, mode)
                        && unexplained.len() <= color_tolerance(format, mode) + 2,
                    "{what}: {} color pixels differ from the native render: {:?}",
                    unexplained.len(),
                    &unexplained[..unexplained.len().min(4)]
                );
            } else {
                let colors = differing_pixels(&native_color, &color);
                assert!(
                    colors <= color_tolerance(format, mode),
                    "{what}: {colors} color pixels differ from the native render"
                );
            }
        }
    }
    eprintln!(
        "{format}: {checked} reversed read-backs checked; refused by the tester: {refused:?}"
    );
    // Only scenes that need what lavapipe or the format lacks may be refused.
    for scene in &refused {
        assert!(
            ["depth-bounds", "stencil", "stencil-reads"].contains(&scene.as_str()),
            "{format}: the tester refused {scene}"
        );
    }
    assert!(
        checked >= 90,
        "{format}: only {checked} reversed read-backs"
    );
}

#[test]
fn default_policy_hands_back_native_depth_d16() {
    default_policy_hands_back_native_depth("d16");
}

#[test]
fn default_policy_hands_back_native_depth_x8_d24() {
    default_policy_hands_back_native_depth("x8-d24");
}

#[test]
fn default_policy_hands_back_native_depth_d24_s8() {
    default_policy_hands_back_native_depth("d24-s8");
}

#[test]
fn default_policy_hands_back_native_depth_d32() {
    default_policy_hands_back_native_depth("d32");
}

#[test]
fn default_policy_hands_back_native_depth_d32_s8() {
    default_policy_hands_back_native_depth("d32-s8");
}

/// A route's marker for `REVZ_REVERSE_OBSERVABLE=all`.
const REVERSE_ALL: &str = "reverse-all";

/// The copy routes, each against the direct copy of the same mode: bit-identical, but for the
/// device's own blit rounding and infinite mode's round trips (below).
#[test]
fn every_copy_route_reads_back_what_the_direct_copy_does() {
    let harness = Harness::locate();
    let routes: [&[&str]; 19] = [
        &["--depth-route", "unorm-image"],
        &["--depth-route", "blit-unorm-image"],
        &["--depth-route", "blit-native-image"],
        &["--depth-route", "blit-native-image", "--copy2"],
        &["--depth-route", "image"],
        &["--depth-route", "native-image"],
        &["--depth-route", "buffer", "--depth-row-padding", "3"],
        &[
            "--depth-route",
            "buffer",
            "--copy2",
            "--depth-row-padding",
            "1",
        ],
        &["--depth-route", "native-image", "--copy2"],
        &["--depth-row-padding", "5", "--copy2"],
        // Both aspects of a depth-stencil image in one region: between reversed images as it
        // is, and converted into a native one (the stencil goes down before the converted
        // depth: lavapipe writes the depth too when it copies the stencil alone).
        &["--depth-route", "image", "--copy-all-aspects"],
        &["--depth-route", "native-image", "--copy-all-aspects"],
        // The stencil of a promoted image (D24S8 stored as D32S8) into one that keeps D24S8:
        // through the scratch buffer with the converted depth.
        &["--depth-route", "unorm-image", "--copy-all-aspects"],
        &[
            "--depth-route",
            "native-image",
            "--copy-all-aspects",
            "--copy2",
        ],
        // 3D depth images (issue #44): a 2D image into a slice, read back from its z offset;
        // a blit of a box two slices deep into a 3D image that keeps the UNORM format
        // (converted through a 3D staged image where the first is promoted).
        &["--depth-route", "volume"],
        // Into an image with transfer usage only, which revz keeps native and in its format.
        &["--depth-route", "transfer-image"],
        &["--depth-route", "blit-unorm-volume"],
        &["--depth-route", "blit-unorm-volume", "--copy2"],
        // Every image reversed, the 3D ones too: the blit converts through a 3D staged image
        // where the first 3D image is promoted.
        &["--depth-route", "blit-unorm-volume", REVERSE_ALL],
    ];
    for format in revz_tests::DEPTH_FORMATS {
        // The device's own blit may round (lavapipe blits D24 through float32, one unit off
        // at most texels): measured without the layer, and allowed to the blit routes.
        let blit_rounding = {
            let plain = |name: &str, args: &[&str]| {
                let dir = harness.scratch_dir(&format!("copies-route-{format}-none-{name}"));
                let mut command = tester(&harness, format, &dir, &["--scene", "overlap"]);
                command.args(args);
                harness.render(command, &dir).depth()
            };
            let (direct, blitted) = (
                plain("direct", &[]),
                plain("blit", &["--depth-route", "blit-native-image"]),
            );
            direct
                .iter()
                .zip(&blitted)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max)
        };
        assert!(
            blit_rounding <= 1.0 / 16_777_215.0 * 1.001,
            "{format}: the device's blit rounds by {blit_rounding:e}"
        );
        for mode in REVERSING_MODES {
            let render = |name: &str, args: &[&str]| {
                let dir = harness.scratch_dir(&format!("copies-route-{format}-{mode}-{name}"));
                let mut command = tester(&harness, format, &dir, &["--scene", "overlap"]);
                // REVERSE_ALL is no tester argument: REVZ_REVERSE_OBSERVABLE=all.
                command.args(args.iter().filter(|&&a| a != REVERSE_ALL));
                harness
                    .with_layer(&mut command)
                    .env("REVZ_MODE", mode)
                    .env("REVZ_LOG", "info");
                if args.contains(&REVERSE_ALL) {
                    command.env("REVZ_REVERSE_OBSERVABLE", "all");
                }
                harness.render(command, &dir)
            };
            let direct = render("direct", &[]);
            let log = direct.stderr();
            assert!(
                log.contains("): reversed"),
                "{format} {mode}: the read-back image was not reversed\n{log}"
            );
            for (i, args) in routes.iter().enumerate() {
                let routed = render(&i.to_string(), args);
                let log = routed.stderr();
                assert!(!log.contains("is not converted"), "{args:?}: {log}");
                // A round trip through a buffer maps to standard and back: exact for d -> 1 - d
                // (a bit complement twice), within one step of a UNORM grid for infinite
                // mode's affine map (each way within half a step of the f64 value).
                // In infinite mode the native-image routes' second image (an input
                // attachment) stores complementary depth: the copy into it remaps n / w to
                // 1 - D, and the read-back maps that to standard depth: a round trip too.
                let round_trip = mode == "infinite"
                    && args
                        .iter()
                        .any(|a| *a == "buffer" || a.ends_with("native-image"));
                // A promoted image (D16 and D24 in the precise modes) read back through a
                // second image or a buffer is rounded into its UNORM grid twice where the
                // direct copy rounds once (float32 to the grid, then the grid's values mapped):
                // within one step of the grid; in infinite mode the map scales the first
                // rounding by 1 / (1 - n/f) before the second, so within two (measured: 1.004
                // steps at most, d16 through a UNORM image).
                let twice_rounded = mode != "flip"
                    && args
                        .iter()
                        .any(|a| a.ends_with("image") || a.ends_with("volume") || *a == "buffer");
                // Float: one rounding each way, within one ulp of [0.5, 1) (2^-23).
                let step = match unorm_max(format) {
                    Some(max) if twice_rounded => {
                        let steps = if mode == "infinite" { 2.0 } else { 1.0 };
                        ((steps / max) as f32 * 1.001).max(blit_rounding)
                    }
                    _ if args.iter().any(|a| a.starts_with("blit-")) && !round_trip => {
                        blit_rounding
                    }
                    _ if !round_trip => 0.0,
                    Some(max) => ((1.0 / max) as f32 * 1.001).max(blit_rounding),
                    None => 1.2e-7f32.max(blit_rounding),
                };
                let (depth, reference) = (routed.depth(), direct.depth());
                let off: Vec<f32> = depth
                    .iter()
                    .zip(&reference)
                    .map(|(a, b)| (a - b).abs())
                    .filter(|&d| d > step || (step == 0.0 && d != 0.0))
                    .collect();
                let worst = off.iter().copied().fold(0.0, f32::max);
                assert!(
                    off.is_empty(),
                    "{format} {mode} {args:?}: {} of {} pixels read back other values than the \
                     direct copy (worst {worst:e}, allowed {step:e})",
                    off.len(),
                    depth.len()
                );
            }
        }
    }
}

/// A Vulkan 1.0 application gets the same converted copies (revz's sequence uses 1.0 commands
/// only and its shader is SPIR-V 1.0 without extensions): bit-identical to Vulkan 1.3.
#[test]
fn vulkan_1_0_applications_get_the_same_converted_copies() {
    let harness = Harness::locate();
    for format in ["d16", "d32-s8"] {
        for mode in REVERSING_MODES {
            let render = |version: &str| {
                let dir = harness.scratch_dir(&format!("copies-vk{version}-{format}-{mode}"));
                let mut command = tester(
                    &harness,
                    format,
                    &dir,
                    &["--scene", "overlap", "--vulkan", version],
                );
                harness
                    .with_layer(&mut command)
                    .env("REVZ_MODE", mode)
                    .env("REVZ_LOG", "info");
                harness.render(command, &dir)
            };
            let (old, new) = (render("1.0"), render("1.3"));
            let log = old.stderr();
            assert!(log.contains("): reversed"), "{format} {mode}: {log}");
            assert!(!log.contains("is not converted"), "{format} {mode}: {log}");
            let same = old
                .depth()
                .iter()
                .zip(&new.depth())
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(
                same,
                "{format} {mode}: Vulkan 1.0 reads back other depth than 1.3"
            );
        }
    }
}
