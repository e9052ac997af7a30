//! Multi-threaded recording under stress (issue #18): `revz-tester stress-threads` on lavapipe
//! under the validation layer, without revz and through it in every mode. Each frame, 8
//! threads record at once, each into a secondary of its own command pool (half of them
//! inheriting the framebuffer, half the render pass only), binding, setting the viewport and
//! pushing per-object matrices; one primary executes them. The tester fails unless every frame
//! from the second on is bit-identical to the second (the first is a warm-up: revz learns each
//! camera's best matrix across frames); this test then checks that frame: zero validation
//! messages, every visible object drawn in its color where the ground truth says it is
//! visible, colors equal to the native render, and the depth reversed as the mode says
//! (`off`: identical; `flip`: 1 - native; `complementary`: 1 - the standard mapping of the
//! ground truth's w; `infinite`: n / w), the background at the reversed clear value.
//!
//! Frames per run: `REVZ_STRESS_FRAMES` (default [`DEFAULT_FRAMES`], a few seconds per mode).
//! ThreadSanitizer is not used: it needs a nightly toolchain (`-Zsanitizer=thread`, and an
//! instrumented std), which this project does not build with.

use std::sync::OnceLock;

use revz_tests::{
    clean_command, differing_depths, differing_pixels, flip_tolerance,
    unexplained_color_differences, GroundTruth, Harness, Render, BACKGROUND,
};

const FRAMES_ENV: &str = "REVZ_STRESS_FRAMES";
const DEFAULT_FRAMES: u32 = 500;
const THREADS: u32 = 8;
const FORMAT: &str = "d32";

fn frames() -> u32 {
    std::env::var(FRAMES_ENV)
        .ok()
        .map(|v| v.parse().expect("REVZ_STRESS_FRAMES is a count"))
        .unwrap_or(DEFAULT_FRAMES)
}

/// Runs the stress through revz in `mode`, or without it.
fn stress(harness: &Harness, mode: Option<&str>) -> Render {
    let dir = harness.scratch_dir(&format!("threads-stress-{}", mode.unwrap_or("native")));
    let mut command = clean_command(&harness.tester);
    command
        .arg("stress-threads")
        .args(harness.tester_args(FORMAT, &dir))
        .args(["--threads", &THREADS.to_string()])
        .args(["--frames", &frames().to_string()]);
    if let Some(mode) = mode {
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", mode)
            .env("REVZ_REVERSE_OBSERVABLE", "copies")
            .env("REVZ_COPY_VALUES", "stored")
            .env("REVZ_LOG", "info");
    }
    let render = harness.render(command, &dir);
    let text = std::fs::read_to_string(dir.join("stress.json")).expect("stress.json");
    let report: serde_json::Value = serde_json::from_str(&text).expect("stress.json parses");
    assert_eq!(report["threads"], THREADS, "{report}");
    assert_eq!(report["frames"], frames(), "{report}");
    assert_eq!(
        report["differing_frames"],
        serde_json::json!([]),
        "{report}"
    );
    // Shown with --nocapture: the figures for docs/testing.md.
    eprintln!(
        "{}: {THREADS} threads x {} frames in {:.2} s",
        mode.unwrap_or("native"),
        frames(),
        report["seconds"].as_f64().expect("seconds")
    );
    render
}

/// The native render, shared by the tests of every mode, and its ground truth.
fn native() -> &'static (Render, GroundTruth) {
    static NATIVE: OnceLock<(Render, GroundTruth)> = OnceLock::new();
    NATIVE.get_or_init(|| {
        let harness = Harness::locate();
        let render = stress(&harness, None);
        let truth = render.ground_truth();
        assert_drawn(&render, &truth, "native");
        (render, truth)
    })
}

/// Every object is visible somewhere, and at every interior pixel the render shows the color
/// of the object the ground truth says is nearest there.
fn assert_drawn(render: &Render, truth: &GroundTruth, label: &str) {
    for object in &truth.objects {
        assert!(
            truth.ids.contains(&object.id),
            "{label}: {} is hidden in the ground truth",
            object.name
        );
    }
    let color = render.color();
    let wrong: Vec<usize> = (0..truth.ids.len())
        .filter(|&at| truth.w[at].is_finite() && truth.ids[at] != BACKGROUND)
        .filter(|&at| {
            let pixel = color.get_pixel((at % truth.width) as u32, (at / truth.width) as u32);
            pixel.0 != truth.object(truth.ids[at]).color
        })
        .collect();
    assert!(
        wrong.is_empty(),
        "{label}: {} interior pixels do not show their object's color (first at {})",
        wrong.len(),
        wrong[0]
    );
}

/// The largest |depth - expected(w)| / bound over the interior pixels, and the background.
fn check_depth(
    render: &Render,
    truth: &GroundTruth,
    label: &str,
    expected: impl Fn(f64) -> (f64, f64),
) {
    let depth = render.depth();
    let mut worst: f64 = 0.0;
    for (at, (&stored, &w)) in depth.iter().zip(&truth.w).enumerate() {
        if !w.is_finite() {
            continue;
        }
        let (value, bound) = expected(w);
        let ratio = (f64::from(stored) - value).abs() / bound;
        assert!(
            ratio <= 1.0,
            "{label}: pixel {at}: depth {stored:e}, expected {value:e} within {bound:e}"
        );
        worst = worst.max(ratio);
    }
    eprintln!("{label}: worst depth error {worst:.3} x the bound");
    for at in truth.open_background() {
        assert_eq!(depth[at], 0.0, "{label}: background pixel {at}");
    }
}

/// Through revz in `mode`: clean, every frame equal, every object drawn, the native colors.
fn layered(mode: &str) -> (Render, &'static Render, &'static GroundTruth) {
    let (native, truth) = native();
    let harness = Harness::locate();
    let render = stress(&harness, Some(mode));
    assert_eq!(render.loaded_mode().as_deref(), Some(mode));
    assert_drawn(&render, truth, mode);
    (render, native, truth)
}

#[test]
fn off_is_bit_identical() {
    let (render, native, _) = layered("off");
    assert_eq!(differing_pixels(&native.color(), &render.color()), 0);
    assert_eq!(differing_depths(&native.depth(), &render.depth()), 0);
}

#[test]
fn flip_reverses_every_draw_of_every_thread() {
    let (render, native, truth) = layered("flip");
    assert!(
        render.stderr().contains("): reversed"),
        "{}",
        render.stderr()
    );
    assert_eq!(differing_pixels(&native.color(), &render.color()), 0);
    let native_depth = native.depth();
    let bound = f64::from(flip_tolerance(FORMAT));
    for (at, (n, f)) in native_depth.iter().zip(render.depth()).enumerate() {
        let error = ((1.0 - f64::from(*n)) - f64::from(f)).abs();
        assert!(error <= bound, "flip: pixel {at}: {f} is not 1 - {n}");
    }
    for at in truth.open_background() {
        assert_eq!(render.depth()[at], 0.0, "flip: background pixel {at}");
    }
}

/// Complementary and infinite: the colors are the native ones (where they differ, at an
/// intersection line, the ground truth's nearest object), the depth the reversed mapping of
/// the ground truth's w.
fn precise(mode: &str, expected: impl Fn(f64, f64, f64) -> (f64, f64)) {
    let (render, native, truth) = layered(mode);
    assert!(
        render.stderr().contains("): reversed"),
        "{}",
        render.stderr()
    );
    let unexplained = unexplained_color_differences(&native.color(), &render.color(), truth);
    assert!(unexplained.is_empty(), "{mode}: {}", unexplained.join("; "));
    let (near, far) = (truth.near, truth.far);
    check_depth(&render, truth, mode, |w| expected(near, far, w));
}

#[test]
fn complementary_rewrites_every_push_of_every_thread() {
    // 1 - D_standard(w) = n (f - w) / (w (f - n)), within 3e-5 relative: each pushed float32
    // matrix determines n only to its rounding (tests/precise.rs checks the precision against
    // each pushed matrix's own range; about 1e-5 here): what matters here is that every draw
    // of every thread took the mode's mapping.
    precise("complementary", |n, f, w| {
        let value = n * (f - w) / (w * (f - n));
        (value, 3e-5 * value)
    });
}

#[test]
fn infinite_rewrites_every_push_of_every_thread() {
    // n / w, within the same relative bound (the flip path's 1 - D_standard is 5% away).
    precise("infinite", |n, _, w| {
        let value = n / w;
        (value, 3e-5 * value)
    });
}
