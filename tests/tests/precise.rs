//! End-to-end tests of the precise path (issue #3): the tester's scenes that hand their
//! projection to the shader in the ways applications do (a bare P, P * V, P * V * M, a model
//! and a view-projection matrix side by side, row-major storage, OpenGL depth, partial push
//! updates, recording on several threads), rendered on lavapipe under the validation layer,
//! checked pixel by pixel against the tester's computed ground truth (`expected-w.f64`: the
//! exact view-space w of the visible surface at every interior pixel).
//!
//! - `ground_truth::*` (no layer): the native depth is the camera's standard mapping of the
//!   ground truth's w within [`depth_floor`]: this proves the ground truth and the floor.
//! - `precise::*`: through revz in `complementary` and `infinite` mode (and `infinite` with
//!   `far_clip=keep`), depth readback allowed (`reverse_observable=copies`): zero validation
//!   messages, the color image identical to the native one (at interior pixels; elsewhere a
//!   difference must show the object the ground truth says is nearest: an intersection line
//!   where two surfaces are closer at a pixel center than standard depth resolves, and the
//!   layer got right), and the depth read back equal to the reversed mapping of the ground
//!   truth's w within [`depth_floor`].
//! - `flip_does_not_meet_the_precise_bound`: the flip path stores 1 - D_standard, which is
//!   correct but carries standard depth's rounding near 1: it must fail the same check, or the
//!   check would not show that the projection was rewritten.
//! - `multiview_every_view_against_its_own_camera`: both views of the multiview scenes (two
//!   eyes, one draw each), every layer read back against the ground truth of its own camera,
//!   natively and through revz, in every depth format.
//! - `already_reversed_is_left_alone`: an application with its own reversed projection renders
//!   bit-identically with and without the layer, in every mode, and the layer says so.
//!
//! # The reference
//!
//! For each object the reference mapping uses the visible range (n', f') of the matrix the
//! application actually pushed (float32), recovered with `revz-math` in f64 exactly as the
//! layer does: complementary `n' (f' - w) / (w (f' - n'))` (= 1 - D_standard(w)), infinite
//! `n' / w`. Not the camera's f64 (n, f): a precomposed float32 matrix only determines its depth
//! row to its own rounding (its translation entry is about `k * r3[3] + B` with `|k r3[3]|`
//! some 100 times `|B|` for these cameras), so its n' differs from the camera's n by up to about
//! 2e-6 relative (measured on `overlap`), and that is what any layer, however exact, reproduces.
//! The ground truth's w, on the other hand, comes from the f64 matrices (what the application
//! meant); the float32 evaluation of w is part of the floor below.
//!
//! # The floor
//!
//! [`depth_floor`] bounds |stored - reference| at an interior pixel for a stored mapping
//! `D(w) = k + B / w`, with u = 2^-24, gamma_4 = 4u / (1 - 4u) (the running error of a float32
//! dot product of 4 terms, as in `revz_math::precision`), and c = the object's `w_condition`
//! (the GPU's w is within `(u + gamma_4) c w` of the exact w; about 1 to 3 here):
//!
//! ```text
//! (u + gamma_4) (|k| c + |B| / w + |D| c)      vertex stage: the depth row rounded to float32
//!                                               and evaluated, and the error of w
//! + 2u |D| * (2.5 + 4 + 0.5)                   division (2.5 ulp, Vulkan's bound), rasterizer
//!                                               interpolation (4 ulp), storing (0.5 ulp)
//! + one step of the format's grid (D24: 2^-24; D32: 0)
//! ```
//!
//! Vertex errors carry over to the pixel: depth is interpolated linearly in screen space, with
//! the same weights as the depth itself, so an error relative to D at the vertices stays
//! relative to D at the pixel, and the `|B| / w` term interpolates to `|B| / w` at the pixel
//! (1/w is affine in screen space too). For the reversed mappings (|k| <= n/(f-n), D ~ n/w) the
//! floor is a relative tolerance of about `(u + gamma_4)(1 + c) + 14u`, 1e-6 to 2e-6 for these
//! scenes; for standard depth near 1 it is an absolute one of 2e-6 to 3e-6.
//! Measured on lavapipe: native standard depth is within 3.1e-7 of its reference (5 ulps of
//! 1), an application's own float32 complementary projection (`already-reversed`) within
//! 3.3e-7 relative: the floor holds with a margin of 5 or more. The flip path on
//! `view-projection` is off by up to about 1e-2 relative (its surfaces 860 away have
//! 1 - D ~ 1e-4, stored to 6e-8), on `overlap` by about 2e-5.

use revz_math::precision::{float32_gamma, F32_UNIT_ROUNDOFF};
use revz_math::shader_fit::fit_in_shader;
use revz_math::{
    classify, read_clip_transform, CameraMatch, Cameras, DepthConvention, DepthLine, Storage,
};
use revz_tests::{
    compare_depth, differing_depths, differing_pixels, unexplained_color_differences,
    DepthComparison, GroundTruth, Harness, Render, TruthObject,
};

/// The render size of every test here: small, lavapipe is a CPU.
const SIZE: [&str; 4] = ["--width", "96", "--height", "64"];

/// Ulps (of the stored value) allowed after the vertex stage: division 2.5, interpolation 4,
/// storing 0.5.
const RASTER_ULPS: f64 = 7.0;

/// The substring of the layer's info line for an application it leaves alone.
const ALREADY_REVERSED_LINE: &str = "already uses reversed depth";

/// A stored depth mapping `D(w) = k + b / w` (viewport [0, 1]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Mapping {
    k: f64,
    b: f64,
    kind: Kind,
    near: f64,
    far: f64,
}

/// Which mapping, for evaluating it in its most accurate form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// `f / (f - n) * (1 - n / w)`: near 0, far 1.
    Standard,
    /// `n (f - w) / (w (f - n))` = 1 - standard: near 1, far 0.
    Complementary,
    /// `n / w`: near 1, infinity 0.
    Infinite,
}

impl Mapping {
    fn new(kind: Kind, near: f64, far: f64) -> Mapping {
        // Complementary Z of a range without a far plane is infinite reversed Z.
        let kind = if kind == Kind::Complementary && far.is_infinite() {
            Kind::Infinite
        } else {
            kind
        };
        let (k, b) = match kind {
            Kind::Standard => (far / (far - near), -far * near / (far - near)),
            Kind::Complementary => (-near / (far - near), far * near / (far - near)),
            Kind::Infinite => (0.0, near),
        };
        Mapping {
            k,
            b,
            kind,
            near,
            far,
        }
    }

    /// The stored depth at view distance `w`, in f64.
    fn at(self, w: f64) -> f64 {
        let (n, f) = (self.near, self.far);
        match self.kind {
            Kind::Standard => f / (f - n) * (1.0 - n / w),
            Kind::Complementary => n * (f - w) / (w * (f - n)),
            Kind::Infinite => n / w,
        }
    }
}

/// The bound on |stored - reference| at an interior pixel (derivation in the module docs).
///
/// With `negativeOneToOne` the pipeline computes z_ndc = 2D - 1 (the mapping's clip-space form
/// is k_ndc = 2k - 1, B_ndc = 2B) and the viewport stores (z_ndc + 1) / 2: every error of the
/// vertex stage and of the division is relative to |z_ndc| ~ 1, not to the stored D, and the
/// addition rounds once more. Near the far plane of a reversed mapping (D ~ 0, z_ndc ~ -1)
/// that is an absolute floor of a few u whatever the layer does: the OpenGL convention's own
/// cancellation, which only a pipeline clipping to [0, 1] would avoid.
fn depth_floor(
    mapping: Mapping,
    reference: f64,
    w: f64,
    w_condition: f64,
    format: &str,
    negative_one_to_one: bool,
) -> f64 {
    let u = F32_UNIT_ROUNDOFF;
    let (k, b, d) = if negative_one_to_one {
        (
            2.0 * mapping.k - 1.0,
            2.0 * mapping.b,
            2.0 * reference - 1.0,
        )
    } else {
        (mapping.k, mapping.b, reference)
    };
    let scale = if negative_one_to_one { 0.5 } else { 1.0 };
    let vertex = scale
        * (u + float32_gamma(4))
        * (k.abs() * w_condition + b.abs() / w + d.abs() * w_condition);
    let viewport = if negative_one_to_one { u } else { 0.0 };
    let raster = scale * RASTER_ULPS * 2.0 * u * d.abs() + viewport;
    let grid = match format {
        "x8-d24" | "d24-s8" => 1.0 / 16_777_215.0,
        "d16" => 1.0 / 65_535.0,
        _ => 0.0,
    };
    vertex + raster + grid + f64::from(f32::MIN_POSITIVE)
}

/// The visible range (n', f') of the matrix pushed for `object`, recovered in f64 under the
/// application's depth convention, as the layer recovers it.
fn pushed_range(object: &TruthObject, truth: &GroundTruth) -> (f64, f64) {
    let convention = if truth.negative_one_to_one {
        DepthConvention::NegativeOneToOne
    } else {
        DepthConvention::ZeroToOne
    };
    let m = read_clip_transform(&object.pushed_projection, Storage::ColumnMajor);
    let range = classify(&m, convention).range().unwrap_or_else(|| {
        panic!(
            "{}: the pushed matrix is not a perspective: {:?}",
            object.name,
            classify(&m, convention)
        )
    });
    (range.near(), range.far())
}

/// The visible range the layer uses for each object (in `truth.objects` order, the order
/// they are drawn in): its camera's (`revz_math::Cameras`) as the layer classifies them in one
/// recording, whose table pins a camera's range at its first trusted matrix (session 39:
/// every draw of a camera in a recording on one line); an object whose matrix matches no
/// trusted camera keeps its own.
fn layer_ranges(truth: &GroundTruth) -> Vec<(f64, f64)> {
    ranges_of(truth, Cameras::default().pinning_ranges())
}

/// The range each object's camera has after all of them, from its best-conditioned matrix:
/// what the device's table holds after the recording's submission, which the next frame's
/// recordings begin with.
fn best_ranges(truth: &GroundTruth) -> Vec<(f64, f64)> {
    let mut cameras = Cameras::default();
    for object in &truth.objects {
        let m = read_clip_transform(&object.pushed_projection, Storage::ColumnMajor);
        cameras.observe(&m, convention_of(truth));
    }
    ranges_of(truth, cameras)
}

fn convention_of(truth: &GroundTruth) -> DepthConvention {
    if truth.negative_one_to_one {
        DepthConvention::NegativeOneToOne
    } else {
        DepthConvention::ZeroToOne
    }
}

/// The ranges of [`layer_ranges`], classified against `cameras`.
fn ranges_of(truth: &GroundTruth, mut cameras: Cameras) -> Vec<(f64, f64)> {
    let convention = convention_of(truth);
    truth
        .objects
        .iter()
        .map(|object| {
            let m = read_clip_transform(&object.pushed_projection, Storage::ColumnMajor);
            match cameras.observe(&m, convention) {
                CameraMatch::Camera { range, .. } => (range.near(), range.far()),
                _ => pushed_range(object, truth),
            }
        })
        .collect()
}

/// What the layer is asked to do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Case {
    mode: &'static str,
    keep_far_clip: bool,
}

const COMPLEMENTARY: Case = Case {
    mode: "complementary",
    keep_far_clip: false,
};
const INFINITE: Case = Case {
    mode: "infinite",
    keep_far_clip: false,
};
const INFINITE_KEEP: Case = Case {
    mode: "infinite",
    keep_far_clip: true,
};

impl Case {
    fn label(self) -> String {
        if self.keep_far_clip {
            format!("{}+keep", self.mode)
        } else {
            self.mode.to_owned()
        }
    }

    /// The reference mapping of an object under this case: its camera's range as the layer
    /// uses it ([`layer_ranges`]).
    fn mapping(self, object: &TruthObject, truth: &GroundTruth) -> Mapping {
        let index = truth
            .objects
            .iter()
            .position(|o| std::ptr::eq(o, object))
            .expect("an object of this ground truth");
        let (near, far) = layer_ranges(truth)[index];
        match self.mode {
            "infinite" => Mapping::new(Kind::Infinite, near, far),
            _ => Mapping::new(Kind::Complementary, near, far),
        }
    }
}

/// Scenes rendered on [`Harness::newer_lavapipe`] where there is one: Mesa 22.3's lavapipe
/// leaves the ground (the one object its clipper cuts: its near corners lie far outside the
/// frustum's sides) out of view 1 of a multiview pass, with or without revz and with no
/// validation message: at 256 x 256 in D32 layer 1 covers 21,679 pixels (the cubes), and
/// 34,204 of its 53,747 interior pixels hold the clear depth where the ground truth sees the
/// ground; Mesa 25.0's covers 56,112, every interior pixel within 2.9e-7 of the truth.
const NEWER_LAVAPIPE_SCENES: [&str; 2] = ["multiview", "multiview-dynamic"];

/// Renders `scene` at the test size, without the layer (`case` None) or through it with depth
/// readback allowed; `label` keeps scratch directories of parallel tests apart.
fn render(harness: &Harness, label: &str, scene: &str, format: &str, case: Option<Case>) -> Render {
    let mode = case.map_or("native".to_owned(), Case::label);
    let dir = harness.scratch_dir(&format!("precise-{label}-{scene}-{format}-{mode}"));
    let mut command = harness.tester(format, &dir);
    command.args(["--scene", scene]).args(SIZE);
    if NEWER_LAVAPIPE_SCENES.contains(&scene) {
        harness.on_newer_lavapipe(&mut command);
    }
    if let Some(case) = case {
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", case.mode)
            .env("REVZ_REVERSE_OBSERVABLE", "copies")
            .env("REVZ_COPY_VALUES", "stored")
            .env("REVZ_LOG", "info");
        if case.keep_far_clip {
            command.env("REVZ_FAR_CLIP", "keep");
        }
    }
    let render = harness.render(command, &dir);
    if let Some(case) = case {
        assert_eq!(
            render.loaded_mode().as_deref(),
            Some(case.mode),
            "{}",
            render.stderr()
        );
    }
    render
}

/// Compares a render's depth with `mapping_of(object)` at the ground truth's interior pixels.
fn compare(
    render: &Render,
    truth: &GroundTruth,
    format: &str,
    mapping_of: impl Fn(&TruthObject) -> Mapping,
) -> DepthComparison {
    compare_depth(&render.depth(), truth, |object, w| {
        let mapping = mapping_of(object);
        let reference = mapping.at(w);
        (
            reference,
            depth_floor(
                mapping,
                reference,
                w,
                object.w_condition,
                format,
                truth.negative_one_to_one,
            ),
        )
    })
}

/// [`compare`] for a scene recorded on several threads at once (`threads`): the recordings of
/// a frame share the range each camera new to the device was first met with
/// (`revz::precise::FirstSeen`, session 39), so every draw stores depth on one line, but which
/// object's matrix was met first depends on timing. The render holds where one of the ranges
/// the layer can have pinned (each trusted line's own, and the camera's in draw order) holds
/// at every interior pixel; the comparison of the range that fits best. (Before session 39
/// each pixel was allowed its own: each recording pinned, or improved, the camera on its own.)
fn compare_one_camera_line(
    render: &Render,
    truth: &GroundTruth,
    format: &str,
    case: Case,
) -> DepthComparison {
    let mut ranges = layer_ranges(truth);
    for object in &truth.objects {
        let m = read_clip_transform(&object.pushed_projection, Storage::ColumnMajor);
        if DepthLine::of(&m).is_some_and(|line| line.is_trusted()) {
            ranges.push(pushed_range(object, truth));
        }
    }
    let kind = if case.mode == "infinite" {
        Kind::Infinite
    } else {
        Kind::Complementary
    };
    ranges
        .iter()
        .map(|&(near, far)| compare(render, truth, format, |_| Mapping::new(kind, near, far)))
        .min_by(|a, b| {
            (a.failures, a.worst_ratio)
                .partial_cmp(&(b.failures, b.worst_ratio))
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .expect("at least the camera's range")
}

fn describe(what: &str, comparison: &DepthComparison) -> String {
    format!(
        "{what}: {} of {} interior pixels outside the floor; worst error {:.2} x the floor, \
         worst relative error {:.3e}; worst pixel: {}",
        comparison.failures,
        comparison.checked,
        comparison.worst_ratio,
        comparison.worst_relative,
        comparison.worst
    )
}

/// Without the layer, the depth in `format` of every view (a multiview render's each) is its
/// camera's own mapping (standard, or complementary for `already-reversed`) of the view's
/// ground truth's w within the floor, and the open background holds the clear value: the
/// ground truth says what was rendered.
fn ground_truth_holds(scene: &str, format: &str) {
    let harness = Harness::locate();
    for native in render(&harness, "truth", scene, format, None).views() {
        view_truth_holds(scene, format, &native);
    }
}

/// [`ground_truth_holds`] of one view.
fn view_truth_holds(scene: &str, format: &str, native: &Render) {
    let truth = native.ground_truth();
    assert!(
        truth.interior() > truth.width * truth.height / 2,
        "{scene}: only {} interior pixels",
        truth.interior()
    );
    let kind = if truth.reversed {
        Kind::Complementary
    } else {
        Kind::Standard
    };
    let camera = Mapping::new(kind, truth.near, truth.far);
    let comparison = compare(native, &truth, format, |_| camera);
    // Shown with --nocapture: the margin, for the record.
    eprintln!("native {}", describe(scene, &comparison));
    assert!(comparison.holds(), "{}", describe(scene, &comparison));
    let clear = if truth.reversed { 0.0 } else { 1.0 };
    let depth = native.depth();
    for at in truth.open_background() {
        assert_eq!(depth[at], clear, "{scene}: background pixel {at}");
    }
    // Every pushed matrix renders the camera's range, to its float32 rounding: the precise
    // references (which use the pushed ranges) are the camera's mapping to about 1e-5.
    for object in &truth.objects {
        let (near, far) = pushed_range(object, &truth);
        assert!(
            (near / truth.near - 1.0).abs() < 1e-5 && (far / truth.far - 1.0).abs() < 1e-3,
            "{scene}: {} pushes a matrix of range [{near}, {far}]",
            object.name
        );
    }
}

/// The precise path on `scene` in `format`, for each case: clean, the native colors, the
/// reversed mapping of the ground truth within the floor, and the cleared background.
fn precise_path(scene: &str, format: &str, cases: &[Case]) {
    let harness = Harness::locate();
    let native = render(&harness, "precise", scene, format, None);
    let truth = native.ground_truth();
    let mut problems = Vec::new();
    for &case in cases {
        let label = case.label();
        let layered = render(&harness, "precise", scene, format, Some(case));
        if !layered.stderr().contains("): reversed") {
            problems.push(format!(
                "{label}: the depth attachment was not reversed: {}",
                layered.stderr()
            ));
        }
        let (native_color, layered_color) = (native.color(), layered.color());
        let unexplained = unexplained_color_differences(&native_color, &layered_color, &truth);
        if !unexplained.is_empty() {
            problems.push(format!(
                "{label}: {} color pixels differ from the native render where the ground \
                 truth does not explain it: {}",
                unexplained.len(),
                unexplained.join("; ")
            ));
        }
        let comparison = if scene == "threads" {
            compare_one_camera_line(&layered, &truth, format, case)
        } else {
            compare(&layered, &truth, format, |o| case.mapping(o, &truth))
        };
        // Shown with --nocapture: the margins of passing checks, for the record.
        eprintln!(
            "{scene} {format}: {} ({} color pixels differ, all explained)",
            describe(&label, &comparison),
            differing_pixels(&native_color, &layered_color) - unexplained.len()
        );
        if !comparison.holds() {
            problems.push(describe(&label, &comparison));
        }
        // The clear value: 1.0 flipped to 0 (the far end of both reversed mappings). With the
        // far plane kept, the layer clears to n/f, known only after a projection was seen: it
        // must at least be one value, behind everything drawn.
        let depth = layered.depth();
        let background: Vec<f32> = truth
            .open_background()
            .iter()
            .map(|&at| depth[at])
            .collect();
        let wrong_background = if case.keep_far_clip {
            background.iter().any(|&d| d != background[0])
        } else {
            background.iter().any(|&d| d != 0.0)
        };
        if wrong_background {
            let mut values = background.clone();
            values.sort_by(f32::total_cmp);
            values.dedup();
            values.truncate(4);
            problems.push(format!("{label}: background depths {values:?}"));
        }
    }
    assert!(
        problems.is_empty(),
        "{scene} {format}:\n  {}",
        problems.join("\n  ")
    );
}

/// One ground-truth test and one precise test per scene (d32, every case).
macro_rules! scene_tests {
    ($($name:ident: $scene:literal;)*) => {
        mod ground_truth {
            $(
                #[test]
                fn $name() {
                    super::ground_truth_holds($scene, "d32");
                }
            )*

            #[test]
            fn already_reversed() {
                super::ground_truth_holds("already-reversed", "d32");
            }
        }

        mod precise {
            use super::{COMPLEMENTARY, INFINITE, INFINITE_KEEP};
            $(
                #[test]
                fn $name() {
                    super::precise_path($scene, "d32", &[COMPLEMENTARY, INFINITE, INFINITE_KEEP]);
                }
            )*

            /// D24 keeps its fixed-point grid: the floor grows by one step, and the test shows
            /// the path is correct there too (not more precise).
            #[test]
            fn overlap_d24_s8() {
                super::precise_path("overlap", "d24-s8", &[COMPLEMENTARY, INFINITE]);
            }
        }
    };
}

scene_tests! {
    overlap: "overlap";
    projection_only: "projection-only";
    view_projection: "view-projection";
    row_major: "row-major";
    opengl_depth: "opengl-depth";
    push_partial: "push-partial";
    threads: "threads";
    secondary: "secondary";
    dynamic_rendering: "dynamic-rendering";
    dynamic_rendering_suspended: "dynamic-rendering-suspended";
    dynamic_rendering_suspended_across: "dynamic-rendering-suspended-across";
    dynamic_rendering_secondaries: "dynamic-rendering-secondaries";
    shadow_map: "shadow-map";
    // A spot light: the shadow casters take the precise path with the light's projection, a
    // second camera; the map's twin is refreshed with the light's n / f in `infinite`.
    shadow_map_perspective: "shadow-map-perspective";
    // The pushed MVP feeds the lighting too (issue #14): only the store to Position may change.
    lit_mvp: "lit-mvp";
}

/// The range a stage that derives it fits from each object's pushed projection (column-major
/// float32): `revz_math::shader_fit::fit_in_shader`'s `k` and `B`, exactly as the stage
/// computes them, as (n, f) = (-B / k, B / (1 - k)).
fn fitted_ranges(truth: &GroundTruth) -> Vec<(f64, f64)> {
    truth
        .objects
        .iter()
        .map(|object| {
            let m = &object.pushed_projection;
            let row = |r: usize| [m[r], m[4 + r], m[8 + r], m[12 + r]];
            let line = fit_in_shader(row(2), row(3)).expect("the stage's fit accepts it");
            let (k, b) = (f64::from(line.k), f64::from(line.b));
            (-b / k, b / (1.0 - k))
        })
        .collect()
}

/// `model-view-projection-pair` pushes 128 bytes, all of lavapipe's push-constant space:
/// revz's carrier has no room (logged), so the vertex stage fits `view_proj` itself, with the
/// carrier baked into the pipeline's reversed variant (issue #41): [`derived_path_problems`].
#[test]
fn a_full_push_constant_space_takes_the_precise_path_with_the_carrier_baked_in() {
    let harness = Harness::locate();
    let problems = derived_path_problems(
        &harness,
        ("full", "model-view-projection-pair", "d32"),
        "no room for revz's 16 bytes",
    );
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// `multiview` and `multiview-dynamic`: both eyes' view-projections in a uniform buffer the
/// vertex stage indexes with `gl_ViewIndex`, so it fits each view's own (docs/precise.md,
/// Multiview). In every depth format, each view's layer against the ground truth of its own
/// camera: natively its standard mapping ([`ground_truth_holds`]), through revz
/// [`derived_path_problems`] (each view complementary depth of the range fitted from its own
/// matrix). Before session 38 layer 1 was checked only through the colors a post pass
/// shades from it.
#[test]
fn multiview_every_view_against_its_own_camera() {
    let harness = Harness::locate();
    let mut problems = Vec::new();
    for scene in ["multiview", "multiview-dynamic"] {
        for format in revz_tests::DEPTH_FORMATS {
            ground_truth_holds(scene, format);
            problems.extend(derived_path_problems(
                &harness,
                ("multiview", scene, format),
                "): reversed",
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// What is wrong with `scene` in `format` through revz in `complementary` and `infinite`
/// where its vertex stage fits the projection it loads (no camera is pushed where revz could
/// read it, so both modes store complementary depth of the range the stage fits), in every
/// view of each render against that view's ground truth: a depth attachment not reversed or
/// `logged` missing from the log, colors the native render's view does not have (where its
/// ground truth does not explain them), depth off that mapping of the ground truth beyond the
/// floor, or the open background not cleared to 0. `label` keeps scratch directories apart.
fn derived_path_problems(
    harness: &Harness,
    (label, scene, format): (&str, &str, &str),
    logged: &str,
) -> Vec<String> {
    let natives = render(harness, label, scene, format, None).views();
    let mut problems = Vec::new();
    for case in [COMPLEMENTARY, INFINITE] {
        let layered = render(harness, label, scene, format, Some(case));
        let log = layered.stderr();
        let what = format!("{scene} {format} {}", case.label());
        if !log.contains(logged) || !log.contains("): reversed") {
            problems.push(format!(
                "{what}: not reversed with '{logged}' logged: {log}"
            ));
        }
        for (view, (native, layered)) in natives.iter().zip(layered.views()).enumerate() {
            let what = format!("{what} view {view}");
            let truth = native.ground_truth();
            let ranges = fitted_ranges(&truth);
            let unexplained =
                unexplained_color_differences(&native.color(), &layered.color(), &truth);
            if !unexplained.is_empty() {
                problems.push(format!("{what}: colors differ: {}", unexplained.join("; ")));
            }
            let comparison = compare(&layered, &truth, format, |object| {
                let index = truth
                    .objects
                    .iter()
                    .position(|o| std::ptr::eq(o, object))
                    .expect("an object of this ground truth");
                let (near, far) = ranges[index];
                Mapping::new(Kind::Complementary, near, far)
            });
            eprintln!("{}", describe(&what, &comparison));
            if !comparison.holds() {
                problems.push(describe(&what, &comparison));
            }
            let depth = layered.depth();
            if truth.open_background().iter().any(|&at| depth[at] != 0.0) {
                problems.push(format!("{what}: the background is not cleared to 0"));
            }
        }
    }
    problems
}

/// The flip path renders `view-projection` correctly (same colors, depth = 1 - native) but
/// with standard depth's precision: checked like the precise path's complementary mode it
/// fails at most pixels, and by far: the check tells a rewritten projection from a flipped
/// viewport.
#[test]
fn flip_does_not_meet_the_precise_bound() {
    let harness = Harness::locate();
    let scene = "view-projection";
    let native = render(&harness, "flip", scene, "d32", None);
    let truth = native.ground_truth();
    let flip = Case {
        mode: "flip",
        keep_far_clip: false,
    };
    let flipped = render(&harness, "flip", scene, "d32", Some(flip));
    assert_eq!(differing_pixels(&native.color(), &flipped.color()), 0);
    let comparison = compare(&flipped, &truth, "d32", |o| {
        COMPLEMENTARY.mapping(o, &truth)
    });
    eprintln!("{}", describe("flip", &comparison));
    assert!(
        comparison.failures * 2 > comparison.checked && comparison.worst_ratio > 100.0,
        "the flip path passes the precise check: {}",
        describe("flip", &comparison)
    );
    // Its depth is still the flipped native depth, within one float32 step near 1.
    let worst = native
        .depth()
        .iter()
        .zip(flipped.depth())
        .map(|(n, f)| ((1.0 - f64::from(*n)) - f64::from(f)).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 1.2e-7, "flip depth is not 1 - native: {worst:e}");
}

/// An application that renders reversed itself (complementary projection, clear 0, GREATER):
/// in every mode the render is bit-identical to the one without the layer, and the layer logs
/// that it left the application alone.
#[test]
fn already_reversed_is_left_alone() {
    let harness = Harness::locate();
    let scene = "already-reversed";
    let native = render(&harness, "left-alone", scene, "d32", None);
    let mut problems = Vec::new();
    let cases = [
        Case {
            mode: "off",
            keep_far_clip: false,
        },
        Case {
            mode: "flip",
            keep_far_clip: false,
        },
        COMPLEMENTARY,
        INFINITE,
        INFINITE_KEEP,
    ];
    for case in cases {
        let label = case.label();
        let layered = render(&harness, "left-alone", scene, "d32", Some(case));
        let colors = differing_pixels(&native.color(), &layered.color());
        let depths = differing_depths(&native.depth(), &layered.depth());
        if colors != 0 || depths != 0 {
            problems.push(format!(
                "{label}: {colors} color pixels and {depths} depth values differ"
            ));
        }
        if case.mode != "off" && !layered.stderr().contains(ALREADY_REVERSED_LINE) {
            problems.push(format!(
                "{label}: no '{ALREADY_REVERSED_LINE}' in the log:\n{}",
                layered.stderr()
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Issue #14's promise for objects far from the camera, each with its own P * V * M: in
/// `infinite` on D32 the depth stored is the camera's n / w within 4 float32 ulps at every
/// decade of distance, where each object's own float32 depth row would give n / w off by up to
/// 2 % at 1e3 n and nothing beyond 1e5 n. n is the camera's as the layer takes it
/// ([`layer_ranges`]): in the first frame, the camera's first trusted matrix pins it for the
/// whole recording (`far-objects` draws unsorted: every object gets the range of the first
/// one); the camera's best n, which the next frame begins with ([`best_ranges`]), must be the
/// scene's within 1e-4.
/// Every decade must have interior pixels.
fn stores_the_cameras_n_over_w(scene: &str, decades: &[f64]) {
    let harness = Harness::locate();
    let native = render(&harness, "decades", scene, "d32", None);
    let truth = native.ground_truth();
    let layered = render(&harness, "decades", scene, "d32", Some(INFINITE));
    let ranges = layer_ranges(&truth);
    let best = best_ranges(&truth).last().expect("objects").0;
    assert!(
        (best / truth.near - 1.0).abs() < 1e-4,
        "{scene}: the camera's best n {best} is not the scene's {}",
        truth.near
    );
    let last = ranges.last().expect("objects").0;
    // The pinned n is the camera's first trusted line's: within that line's bound of B's
    // relative error (and so of n's, to 8u) of the scene's.
    let first_trusted = truth
        .objects
        .iter()
        .filter_map(|object| {
            let m = read_clip_transform(&object.pushed_projection, Storage::ColumnMajor);
            DepthLine::of(&m).filter(DepthLine::is_trusted)
        })
        .next()
        .expect("a trusted line");
    let pinned_error = (last / truth.near - 1.0).abs();
    assert!(
        pinned_error <= first_trusted.relative_b_error() + 1e-6,
        "{scene}: the pinned n {last} is {pinned_error:e} off the scene's {}, beyond its first \
         trusted line's bound {:e}",
        truth.near,
        first_trusted.relative_b_error()
    );
    eprintln!(
        "{scene}: pinned n {pinned_error:.2e} off the scene's (bound {:.2e})",
        first_trusted.relative_b_error()
    );
    let spread = ranges
        .iter()
        .map(|&(n, _)| (n / last - 1.0).abs())
        .fold(0.0, f64::max);
    let near_of = |object: &TruthObject| {
        let index = truth
            .objects
            .iter()
            .position(|o| std::ptr::eq(o, object))
            .expect("an object of this ground truth");
        ranges[index].0
    };
    let mut per_decade = vec![0usize; decades.len()];
    let mut worst_ulps = vec![0.0f64; decades.len()];
    let depth = layered.depth();
    let comparison = compare_depth(&depth, &truth, |object, w| {
        let reference = near_of(object) / w;
        per_decade[decade_of(decades, w)] += 1;
        (
            reference,
            4.0 * revz_math::precision::float32_ulp(reference),
        )
    });
    for (at, (&stored, &w)) in depth.iter().zip(&truth.w).enumerate() {
        if w.is_finite() {
            let reference = near_of(truth.object(truth.ids[at])) / w;
            let ulps = (f64::from(stored) - reference).abs()
                / revz_math::precision::float32_ulp(reference);
            let decade = decade_of(decades, w);
            worst_ulps[decade] = worst_ulps[decade].max(ulps);
        }
    }
    eprintln!(
        "{scene}: worst ulps per decade {worst_ulps:.2?}, pixels {per_decade:?}; n of the \
         objects within {spread:.1e} of the camera's final n"
    );
    assert!(
        per_decade.iter().all(|&count| count > 0),
        "{scene}: a decade without interior pixels: {per_decade:?}"
    );
    assert_eq!(
        comparison.failures,
        0,
        "{}",
        describe(&format!("{scene} n/w within 4 ulp"), &comparison)
    );
}

/// The index of the decade of `decades` (view distances, ascending) that `w` belongs to.
fn decade_of(decades: &[f64], w: f64) -> usize {
    decades
        .iter()
        .rposition(|&d| w >= 0.5 * d)
        .unwrap_or_default()
}

#[test]
fn deep_range_stores_the_cameras_n_over_w_at_every_decade() {
    stores_the_cameras_n_over_w(
        "deep-range",
        &[1e-2, 1e-1, 1.0, 10.0, 1e2, 1e3, 1e4, 1e5, 1e6],
    );
}

/// `deep-range` on the precise path: the reversed mapping of the camera's range within the
/// float32 floor at every interior pixel, in both precise modes (`complementary` stores the
/// complementary depth of the camera's range; its float32 k rounds to 1, so that range's far
/// plane is at infinity and the two modes agree). Colors are not compared with the native
/// render here: natively the application's own rounded matrices clip the cells beyond 1e4 n
/// (conformance checks every pixel against the ground truth instead: none wrong).
#[test]
fn deep_range_meets_the_float32_floor() {
    let harness = Harness::locate();
    let scene = "deep-range";
    let native = render(&harness, "floor", scene, "d32", None);
    let truth = native.ground_truth();
    for case in [COMPLEMENTARY, INFINITE] {
        let layered = render(&harness, "floor", scene, "d32", Some(case));
        let comparison = compare(&layered, &truth, "d32", |o| case.mapping(o, &truth));
        eprintln!("{}", describe(&case.label(), &comparison));
        assert!(
            comparison.holds(),
            "{}",
            describe(&case.label(), &comparison)
        );
    }
}

#[test]
fn far_objects_store_the_cameras_n_over_w_at_every_decade() {
    // `FAR_DISTANCES` of the tester's `far-objects`: 10 n to 1e6 n.
    stores_the_cameras_n_over_w("far-objects", &[1.0, 10.0, 100.0, 1e3, 1e4, 1e5]);
}

/// Two perspective cameras in a frame (`shadow-map-perspective`: a spot light's shadow pass,
/// then the main view; and the same drawn from secondaries), three frames, `infinite` with `far_clip = keep`: each depth image is
/// cleared with the n / f of the camera that draws into it (remembered when its pass ends),
/// never with the other's. Before, the main view was cleared to the light's n / f (0.08,
/// against the camera's n / w of 0.01 to 0.05) and lost every fragment. Colors bit-identical
/// to the render without the layer, with no validation message.
#[test]
fn each_depth_image_is_cleared_with_its_own_cameras_far_plane() {
    let harness = Harness::locate();
    // The second scene records each pass's draws in secondaries on two threads: the primary
    // learns the cameras from the secondaries it executes.
    for scene in [
        "shadow-map-perspective",
        "shadow-map-perspective-secondaries",
    ] {
        cleared_with_its_own_camera(&harness, scene);
    }
}

fn cleared_with_its_own_camera(harness: &Harness, scene: &str) {
    let frames = ["--frames", "3"];
    let dir = harness.scratch_dir(&format!("precise-two-cameras-{scene}-native"));
    let mut command = harness.tester("d32", &dir);
    command.args(["--scene", scene]).args(SIZE).args(frames);
    let native = harness.render(command, &dir);
    for far_clip in ["keep", "remove"] {
        let dir = harness.scratch_dir(&format!("precise-two-cameras-{scene}-{far_clip}"));
        let mut command = harness.tester("d32", &dir);
        command.args(["--scene", scene]).args(SIZE).args(frames);
        harness
            .with_layer(&mut command)
            .env("REVZ_MODE", "infinite")
            .env("REVZ_FAR_CLIP", far_clip)
            .env("REVZ_LOG", "info");
        let layered = harness.render(command, &dir);
        let differ = revz_tests::differing_pixels(&native.color(), &layered.color());
        assert_eq!(
            differ,
            0,
            "{scene} in infinite, far_clip = {far_clip}, 3 frames: {differ} pixels differ\n{}",
            layered.stderr()
        );
    }
}
