//! End-to-end tests of the accuracy report and conformance (issue #6), on lavapipe under the
//! validation layer: the real `revz-tester report` and `revz-tester conformance` commands,
//! their exit status and their JSON.
//!
//! - `seed_cases_standard_fails_and_infinite_d32_holds`: on seed 001's two cases
//!   (`sloped-plane`, `mars-patch`) standard depth (no layer) fails visibly (at least 1 % of the
//!   checked pixels show the wrong object) and revz's infinite reversed D32_SFLOAT render has at
//!   most 1e-4 wrong pixels, with its depth read back reversed.
//! - `conformance_passes_on_lavapipe`: every scene in every mode, on one depth format of each
//!   kind (D16, D24 with stencil, D32), within its stated bound; JUnit XML and JSON written.
//! - `far_objects_resolve_every_decade_with_reversed_float_depth` (issue #14): boxes from 10 n
//!   to 1e6 n, each object with its own P * V * M, touching and intersecting pairs drawn with
//!   different matrices: standard depth fails from 1e4 n on, and revz's complementary and
//!   infinite D32 renders show no wrong pixel at any decade, which takes one depth mapping for
//!   all of a camera's objects.
//! - `plane_stack_agrees_with_the_model`: the measured minimum separations on D32 are within a
//!   factor of 2 of the precision model's wherever both exist, and the report says why where
//!   one does not; and `revz-tester profile --precision` on the profile of a `plane-stack`
//!   render agrees with the same measurements within a factor of 2 (issue #43).
//! - `promoted_formats_match_their_float_rows` (issue #15): in `complementary` and `infinite`,
//!   on `plane-stack` and `deep-range`, revz promotes the D16, X8_D24 and D24_S8 images (drawn
//!   without depth readback, which would prevent it) to D32_SFLOAT, D32_SFLOAT and
//!   D32_SFLOAT_S8_UINT, as the rows' `promoted_format` says from the layer's log, and they
//!   then measure as the float rows do: wrong-pixel fractions within 1e-4 of the D32 (D32_S8)
//!   row's, `plane-stack`'s minimum separations within a factor of 2 of its at every distance.
//!   With `--promote-depth-formats never` (`REVZ_PROMOTE_DEPTH_FORMATS=never`, the same render
//!   otherwise) the D24_S8 row names no promoted format and is worse than D32 by 0.1 or more of
//!   the checked pixels: the comparison would show a layer that does not promote.
//! - `the_demo_shows_the_point` (issue #43): `revz-tester demo`, what `cargo xtask demo` runs,
//!   prints the wrong-pixel table of its hard cases (standard depth wrong on at least 1% of
//!   the checked pixels, revz on at most a tenth of that), writes the labelled picture and
//!   prints the cost per mode.

use std::path::Path;
use std::process::Command;

use revz_tests::{clean_command, Harness};

fn tester(harness: &Harness, subcommand: &str, out: &Path) -> Command {
    let mut command = clean_command(&harness.tester);
    command
        .arg(subcommand)
        .arg("--out")
        .arg(out)
        .arg("--device")
        .arg("llvmpipe")
        .arg("--layer-dir")
        .arg(&harness.explicit_manifest_dir);
    command
}

fn run(mut command: Command) -> (i32, String) {
    let output = command.output().expect("start revz-tester");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    (output.status.code().unwrap_or(-1), text)
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(
        &std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    )
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn row<'a>(
    report: &'a serde_json::Value,
    scene: &str,
    mode: &str,
    format: &str,
) -> &'a serde_json::Value {
    report["rows"]
        .as_array()
        .expect("rows")
        .iter()
        .find(|r| r["scene"] == scene && r["mode"] == mode && r["format"] == format)
        .unwrap_or_else(|| panic!("no row {scene} {mode} {format}"))
}

#[test]
fn seed_cases_standard_fails_and_infinite_d32_holds() {
    let harness = Harness::locate();
    let out = harness.scratch_dir("accuracy-seed-cases");
    let mut command = tester(&harness, "report", &out);
    command.args([
        "--scenes",
        "sloped-plane,mars-patch",
        "--modes",
        "none,infinite",
        "--formats",
        "d32",
    ]);
    let (code, text) = run(command);
    assert_eq!(code, 0, "{text}");
    let report = json(&out.join("report.json"));
    assert!(report["device"].as_str().unwrap().contains("llvmpipe"));
    for scene in ["sloped-plane", "mars-patch"] {
        let standard = row(&report, scene, "none", "d32");
        let infinite = row(&report, scene, "infinite", "d32");
        for r in [standard, infinite] {
            assert!(r["error"].is_null(), "{scene}: {r}");
            assert!(r["checked_pixels"].as_u64().unwrap() > 5000, "{scene}: {r}");
        }
        let wrong = |r: &serde_json::Value| r["wrong_pixel_fraction"].as_f64().unwrap();
        assert!(wrong(standard) >= 0.01, "{scene}: standard {standard}");
        assert!(wrong(infinite) <= 1e-4, "{scene}: infinite {infinite}");
        assert_eq!(standard["depth_reversed"], false, "{scene}");
        assert_eq!(infinite["depth_reversed"], true, "{scene}");
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("| sloped-plane | none |"), "{md}");
    assert!(out.join("images/mars-patch.png").is_file());
}

#[test]
fn far_objects_resolve_every_decade_with_reversed_float_depth() {
    let harness = Harness::locate();
    let out = harness.scratch_dir("accuracy-far-objects");
    let mut command = tester(&harness, "report", &out);
    command.args([
        "--scenes",
        "far-objects",
        "--modes",
        "none,complementary,infinite",
        "--formats",
        "d32",
    ]);
    let (code, text) = run(command);
    assert_eq!(code, 0, "{text}");
    let report = json(&out.join("report.json"));
    let wrong = |r: &serde_json::Value| r["wrong_pixel_fraction"].as_f64().unwrap();
    // (wrong fraction, checked pixels) of each decade's group, 10 n to 1e6 n.
    let decades = |r: &serde_json::Value| -> Vec<(f64, u64)> {
        let decades = r["decades"].as_array().unwrap_or_else(|| panic!("{r}"));
        assert_eq!(decades.len(), 6, "{r}");
        decades
            .iter()
            .map(|d| (wrong(d), d["checked"].as_u64().unwrap()))
            .collect()
    };
    let standard = row(&report, "far-objects", "none", "d32");
    assert!(standard["error"].is_null(), "{standard}");
    assert_eq!(standard["depth_reversed"], false);
    let by_decade = decades(standard);
    assert!(
        by_decade.iter().all(|&(_, checked)| checked > 300),
        "{standard}"
    );
    // Standard depth: right near the eye, wrong far away.
    assert!(by_decade[..3].iter().all(|&(w, _)| w == 0.0), "{standard}");
    assert!(
        by_decade[5].0 >= 0.02 && wrong(standard) >= 5e-3,
        "{standard}"
    );
    let mut problems = Vec::new();
    for mode in ["complementary", "infinite"] {
        let r = row(&report, "far-objects", mode, "d32");
        if !r["error"].is_null() || r["depth_reversed"] != true {
            problems.push(format!("{mode}: {r}"));
            continue;
        }
        let by_decade = decades(r);
        eprintln!(
            "far-objects {mode} d32: wrong {:.3e}; per decade {by_decade:?}",
            wrong(r)
        );
        if wrong(r) > 1e-4 || by_decade.iter().any(|&(w, _)| w > 0.0) {
            problems.push(format!(
                "{mode}: wrong_pixel_fraction {:.3e}, per decade (10 n to 1e6 n) {:?}",
                wrong(r),
                by_decade.iter().map(|d| d.0).collect::<Vec<_>>()
            ));
        }
    }
    assert!(
        problems.is_empty(),
        "far-objects d32:\n  {}",
        problems.join("\n  ")
    );
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("## Per decade (`far-objects`)"), "{md}");
}

#[test]
fn conformance_passes_on_lavapipe() {
    let harness = Harness::locate();
    let out = harness.scratch_dir("accuracy-conformance");
    let mut command = tester(&harness, "conformance", &out);
    command.args(["--formats", "d16,d24-s8,d32"]);
    let (code, text) = run(command);
    assert_eq!(code, 0, "{text}");
    let summary = text
        .lines()
        .find(|l| l.starts_with("revz conformance: "))
        .unwrap_or_else(|| panic!("no summary line: {text}"));
    assert!(summary.contains("PASS"), "{summary}");
    let result = json(&out.join("conformance.json"));
    let total = result["total"].as_u64().unwrap();
    assert_eq!(total, 7 * 4 * 3, "{result}");
    assert_eq!(result["passed"].as_u64().unwrap(), total);
    assert_eq!(result["failed"].as_u64().unwrap(), 0);
    for case in result["cases"].as_array().unwrap() {
        assert!(
            case["bound"].as_f64().is_some() && case["passed"] == true,
            "{case}"
        );
    }
    let xml = std::fs::read_to_string(out.join("junit.xml")).unwrap();
    assert!(xml.starts_with("<?xml"));
    assert!(xml.contains(&format!(
        "<testsuites name=\"revz conformance\" tests=\"{total}\" failures=\"0\">"
    )));
    assert_eq!(xml.matches("<testcase ").count() as u64, total);
}

#[test]
fn conformance_fails_when_a_bound_is_broken() {
    // The layer's manifest directory replaced by one without a layer: every layer mode fails
    // to render, and conformance says so with its exit status.
    let harness = Harness::locate();
    let out = harness.scratch_dir("accuracy-conformance-broken");
    let empty = harness.scratch_dir("accuracy-no-layer");
    let mut command = clean_command(&harness.tester);
    command
        .args([
            "conformance",
            "--device",
            "llvmpipe",
            "--scenes",
            "sloped-plane",
        ])
        .args(["--formats", "d32", "--modes", "none"])
        .arg("--out")
        .arg(&out)
        .arg("--layer-dir")
        .arg(&empty);
    let (code, text) = run(command);
    assert_eq!(code, 1, "no manifest must be an error: {text}");
}

#[test]
fn plane_stack_agrees_with_the_model() {
    let harness = Harness::locate();
    let out = harness.scratch_dir("accuracy-plane-stack");
    let mut command = tester(&harness, "report", &out);
    command.args(["--scenes", "plane-stack", "--formats", "d32"]);
    let (code, text) = run(command);
    assert_eq!(code, 0, "{text}");
    let report = json(&out.join("report.json"));
    let rows = report["min_separation"].as_array().expect("min_separation");
    assert_eq!(rows.len(), 4 * 6, "{report}");
    let mut compared = 0;
    for r in rows {
        let reversed = r["mode"] == "complementary" || r["mode"] == "infinite";
        match r["agrees"].as_bool() {
            // Reversed float depth: within a factor of 2 of the model at every distance.
            Some(agrees) if reversed => {
                assert!(agrees, "measured and model disagree: {r}");
                compared += 1;
            }
            // Standard depth (none, flip): where it disagrees, the report says why.
            Some(agrees) => assert!(agrees || !r["note"].as_str().unwrap().is_empty(), "{r}"),
            None => assert!(!r["note"].as_str().unwrap().is_empty(), "{r}"),
        }
    }
    assert!(compared >= 12, "{compared} comparisons");
    assert!(out.join("plots/min-separation-d32.png").is_file());
    precision_view_agrees_with_the_measurements(&harness, &out, rows);
}

/// `revz-tester profile --precision` (issue #43) on the profile of a `plane-stack` render in
/// `infinite`: its model numbers for D32F, per policy, within a factor of 2 of the minimum
/// separations the report measured at every distance where both resolve (for standard depth,
/// `none` and `flip`, where the report's own model agrees with the measurement: elsewhere the
/// report explains why one cell was luckier than the model's random pairs).
fn precision_view_agrees_with_the_measurements(
    harness: &Harness,
    out: &Path,
    rows: &[serde_json::Value],
) {
    let profile = out.join("revz-profile.json");
    std::fs::remove_file(&profile).ok();
    let render_dir = out.join("profiled");
    let mut command = harness.tester("d32", &render_dir);
    command
        .args(["--scene", "plane-stack", "--no-depth-readback"])
        .args(["--width", "480", "--height", "360"])
        .env("REVZ_MODE", "infinite")
        .env("REVZ_REPORT", &profile);
    harness.with_layer(&mut command);
    harness.render(command, &render_dir);

    let json_path = out.join("precision.json");
    let png = out.join("precision.png");
    let mut command = clean_command(&harness.tester);
    command
        .arg("profile")
        .arg(&profile)
        .arg("--precision")
        .arg("--json")
        .arg(&json_path)
        .arg("--png")
        .arg(&png);
    let (code, text) = run(command);
    assert_eq!(code, 0, "{text}");
    assert!(text.contains("| infinite * | D32F |"), "{text}");
    assert!(png.is_file());
    let precision = json(&json_path);
    let camera = &precision["cameras"][0];
    let distances: Vec<f64> = camera["distances_over_near"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d.as_f64().unwrap())
        .collect();
    let mut compared = 0;
    for measured in rows {
        let policy = measured["mode"].as_str().unwrap();
        let standard = policy == "none" || policy == "flip";
        if standard && measured["agrees"] != true {
            continue;
        }
        let (Some(value), Some(d)) = (
            measured["min_rel_separation"].as_f64(),
            measured["distance_over_near"].as_f64(),
        ) else {
            continue;
        };
        let column = distances
            .iter()
            .position(|&x| (x / d - 1.0).abs() < 1e-9)
            .unwrap_or_else(|| panic!("no column at {d} n: {distances:?}"));
        let model = camera["rows"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["policy"] == policy && r["storage"] == "D32F")
            .unwrap_or_else(|| panic!("no {policy} D32F row: {camera}"))["min_rel_separation"]
            [column]
            .as_f64()
            .unwrap_or_else(|| panic!("{policy} at {d} n: the model resolves nothing: {camera}"));
        let ratio = model / value;
        assert!(
            (0.5..=2.0).contains(&ratio),
            "{policy} at {d} n: measured {value:.2e}, the precision view's model {model:.2e}"
        );
        compared += 1;
    }
    assert!(compared >= 16, "{compared} comparisons");
}

/// The formats revz promotes, the float row each must then match, and what it is promoted to.
const PROMOTED: [(&str, &str, &str); 3] = [
    ("d16", "d32", "D32_SFLOAT"),
    ("x8-d24", "d32", "D32_SFLOAT"),
    ("d24-s8", "d32-s8", "D32_SFLOAT_S8_UINT"),
];

/// `plane-stack`'s measured minimum relative separation per distance (null: none resolves).
fn separations(r: &serde_json::Value) -> Vec<(f64, Option<f64>)> {
    r["min_rel_separation"]
        .as_array()
        .unwrap_or_else(|| panic!("no min_rel_separation: {r}"))
        .iter()
        .map(|p| {
            (
                p["distance_over_near"].as_f64().unwrap(),
                p["min_rel_separation"].as_f64(),
            )
        })
        .collect()
}

#[test]
fn promoted_formats_match_their_float_rows() {
    let harness = Harness::locate();
    let wrong = |r: &serde_json::Value| r["wrong_pixel_fraction"].as_f64().unwrap();
    let out = harness.scratch_dir("accuracy-promoted");
    let mut command = tester(&harness, "report", &out);
    command.args([
        "--scenes",
        "plane-stack,deep-range",
        "--modes",
        "complementary,infinite",
    ]);
    let (code, text) = run(command);
    assert_eq!(code, 0, "{text}");
    let report = json(&out.join("report.json"));
    // What promotion is asked to change, collected so that everything else is checked first.
    let mut problems = Vec::new();
    for scene in ["plane-stack", "deep-range"] {
        for mode in ["complementary", "infinite"] {
            for (format, float, promoted) in PROMOTED {
                let r = row(&report, scene, mode, format);
                let f = row(&report, scene, mode, float);
                let case = format!("{scene} {mode} {format}");
                for x in [r, f] {
                    assert!(x["error"].is_null(), "{case}: {x}");
                    assert!(x["checked_pixels"].as_u64().unwrap() > 5000, "{case}: {x}");
                }
                // The promotable row is drawn without depth readback (its TRANSFER_SRC would
                // keep the format), the float row with it, reversed.
                assert_eq!(r["depth_readback"], false, "{case}: {r}");
                assert!(r["depth_reversed"].is_null(), "{case}: {r}");
                assert_eq!(f["depth_readback"], true, "{case}: {f}");
                assert_eq!(f["depth_reversed"], true, "{case}: {f}");
                assert!(f["promoted_format"].is_null(), "{case}: {f}");
                if r["promoted_format"] != promoted {
                    problems.push(format!(
                        "{case}: promoted_format {}, expected {promoted} (log: {}/{}/log.txt)",
                        r["promoted_format"],
                        out.display(),
                        r["dir"].as_str().unwrap()
                    ));
                }
                let (a, b) = (wrong(r), wrong(f));
                eprintln!("{case}: wrong {a:.3e}, {float} {b:.3e}");
                if (a - b).abs() > 1e-4 {
                    problems.push(format!(
                        "{case}: wrong_pixel_fraction {a:.3e}, {float}'s {b:.3e}: more than 1e-4 apart"
                    ));
                }
                if scene != "plane-stack" {
                    continue;
                }
                let mut compared = 0;
                for ((d, a), (_, b)) in separations(r).into_iter().zip(separations(f)) {
                    let (Some(a), Some(b)) = (a, b) else {
                        continue;
                    };
                    compared += 1;
                    if !(0.5..=2.0).contains(&(a / b)) {
                        problems.push(format!(
                            "{case}: minimum separation at {d:.0e} n {a:.2e}, {float}'s {b:.2e}: \
                             not within a factor of 2"
                        ));
                    }
                }
                // Reversed float depth resolves something at every distance (at least 1e-7
                // to 3.2e-7 relative, the model's 2e-7): comparing fewer would prove little.
                if compared < STACK_DISTANCES_COMPARED {
                    problems.push(format!(
                        "{case}: minimum separations compared at {compared} distances, \
                         fewer than {STACK_DISTANCES_COMPARED}: {:?} against {float}'s {:?}",
                        separations(r),
                        separations(f)
                    ));
                }
            }
        }
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("| plane-stack | complementary |"), "{md}");

    // The mutation guard: the same D24_S8 render with promotion off is worse than D32.
    let never = harness.scratch_dir("accuracy-promoted-never");
    let mut command = tester(&harness, "report", &never);
    command.args([
        "--scenes",
        "plane-stack",
        "--modes",
        "complementary",
        "--formats",
        "d24-s8,d32",
        "--promote-depth-formats",
        "never",
    ]);
    let (code, text) = run(command);
    assert_eq!(code, 0, "{text}");
    let report = json(&never.join("report.json"));
    let (d24, d32) = (
        row(&report, "plane-stack", "complementary", "d24-s8"),
        row(&report, "plane-stack", "complementary", "d32"),
    );
    for r in [d24, d32] {
        assert!(r["error"].is_null(), "{r}");
        assert!(r["promoted_format"].is_null(), "never promoted: {r}");
    }
    assert_eq!(d24["depth_readback"], false, "{d24}");
    let log = std::fs::read_to_string(never.join(d24["dir"].as_str().unwrap()).join("log.txt"))
        .expect("the render's log");
    assert!(
        log.contains("(D24_UNORM_S8_UINT, 480x360): reversed"),
        "the D24_S8 image was not reversed: {log}"
    );
    eprintln!(
        "never: d24-s8 wrong {:.3e}, d32 {:.3e}",
        wrong(d24),
        wrong(d32)
    );
    assert!(
        wrong(d24) >= wrong(d32) + 0.1,
        "unpromoted D24_S8 is not visibly worse than D32: {d24}\n{d32}"
    );
    // The layer takes the value (a layer that does not know it warns and keeps its default).
    let warnings: Vec<&str> = log.lines().filter(|l| l.contains("[revz WARN]")).collect();
    if !warnings.is_empty() {
        problems.push(format!(
            "REVZ_PROMOTE_DEPTH_FORMATS=never was not taken: {}",
            warnings.join("\n")
        ));
    }
    assert!(
        problems.is_empty(),
        "promotion:\n  {}",
        problems.join("\n  ")
    );
}

/// How many of `plane-stack`'s 6 distances a promoted row and its float row must both resolve.
const STACK_DISTANCES_COMPARED: usize = 4;

/// Issue #40: a promotable case read back (its depth image then has TRANSFER_SRC usage, which
/// kept its UNORM format before copies of promoted images were converted) is promoted all the
/// same, and its wrong-pixel fraction is its float row's; the depth it reads back is the
/// standard depth, rounded into its own format.
#[test]
fn promoted_formats_read_back_match_their_float_rows() {
    let harness = Harness::locate();
    let wrong = |r: &serde_json::Value| r["wrong_pixel_fraction"].as_f64().unwrap();
    let out = harness.scratch_dir("accuracy-promoted-readback");
    let mut command = tester(&harness, "report", &out);
    command.args([
        "--scenes",
        "sloped-plane,deep-range,far-objects",
        "--modes",
        "complementary,infinite",
        "--depth-readback-always",
    ]);
    let (code, text) = run(command);
    assert_eq!(code, 0, "{text}");
    let report = json(&out.join("report.json"));
    let mut problems = Vec::new();
    for scene in ["sloped-plane", "deep-range", "far-objects"] {
        for mode in ["complementary", "infinite"] {
            for (format, float, promoted) in PROMOTED {
                let (r, f) = (
                    row(&report, scene, mode, format),
                    row(&report, scene, mode, float),
                );
                let case = format!("{scene} {mode} {format}");
                for x in [r, f] {
                    assert!(x["error"].is_null(), "{case}: {x}");
                    assert_eq!(x["depth_readback"], true, "{case}: {x}");
                    assert_eq!(x["depth_reversed"], true, "{case}: {x}");
                }
                if r["promoted_format"] != promoted {
                    problems.push(format!(
                        "{case}: read back, promoted_format {}, expected {promoted}",
                        r["promoted_format"]
                    ));
                }
                let (a, b) = (wrong(r), wrong(f));
                eprintln!("{case} read back: wrong {a:.3e}, {float} {b:.3e}");
                if (a - b).abs() > 1e-4 {
                    problems.push(format!(
                        "{case}: read back, wrong_pixel_fraction {a:.3e}, {float}'s {b:.3e}"
                    ));
                }
            }
        }
    }
    assert!(
        problems.is_empty(),
        "promotion with readback:\n  {}",
        problems.join("\n  ")
    );
}

/// `revz-tester demo` (issue #43, what `cargo xtask demo` runs after its build): the hard
/// cases without and with revz in `infinite`, its wrong-pixel table, the labelled picture and
/// the cost figure. Standard depth shows the wrong object on at least 1% of the checked
/// pixels in every case, revz on at most a tenth of that; the picture is the two renders
/// side by side; the cost table names every mode with a ratio above 1 (where valgrind is
/// installed, as on CI's machines).
#[test]
fn the_demo_shows_the_point() {
    let harness = Harness::locate();
    let out = harness.scratch_dir("demo");
    let (code, text) = run(tester(&harness, "demo", &out));
    assert_eq!(code, 0, "{text}");
    let report = json(&out.join("report.json"));
    for scene in ["sloped-plane", "mars-patch", "deep-range", "plane-stack"] {
        for format in ["d24-s8", "d32"] {
            let native = row(&report, scene, "none", format)["wrong_pixel_fraction"]
                .as_f64()
                .unwrap();
            let revz = row(&report, scene, "infinite", format)["wrong_pixel_fraction"]
                .as_f64()
                .unwrap();
            assert!(native >= 0.01, "{scene} {format}: {native} without revz");
            assert!(
                revz <= native / 10.0,
                "{scene} {format}: {revz} vs {native}"
            );
            assert!(
                text.contains(&format!("| {scene} | {format} | ")),
                "no table row {scene} {format}: {text}"
            );
        }
    }
    let picture = image::open(out.join("demo.png")).expect("demo.png");
    // Two 160 x 120 renders scaled by 2, 12 px apart, under 72 px of labels.
    assert_eq!((picture.width(), picture.height()), (676, 324));
    let has_valgrind = Command::new("valgrind").arg("--version").output().is_ok();
    if has_valgrind {
        for mode in ["flip", "complementary", "infinite"] {
            let ratio: f64 = text
                .lines()
                .find_map(|l| l.strip_prefix(&format!("| {mode} | ")))
                .and_then(|rest| rest.trim_end_matches(" |").parse().ok())
                .unwrap_or_else(|| panic!("no cost row for {mode}: {text}"));
            assert!((1.0..4.0).contains(&ratio), "{mode}: {ratio}");
        }
    } else {
        assert!(text.contains("valgrind is not installed"), "{text}");
    }
    assert!(text.contains("cargo xtask report"), "{text}");
}
