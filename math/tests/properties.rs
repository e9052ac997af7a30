//! Property tests of the depth math over random cameras, as the application pushes them:
//! P, P*V or P*V*M built in f64 and rounded once to float32, in either storage order.
//!
//! Every check compares against a bound derived from float32 rounding (u = 2^-24 per rounding)
//! and prints the worst ratio error / bound it saw (`cargo test -p revz-math -- --nocapture`).
//! The runs use a fresh random seed; `PROPTEST_RNG_SEED` pins one, and `NO_SHRINK=1` reports
//! the first failing case as generated instead of a shrunk one.
//!
//! Check 1, the recovered range. The application's entries are rounded once, so
//! `|r2_i - r2*_i| <= u |r2*_i|` and the same for r3. The least-squares k then has
//! `|k^ - k| <= 2u |k|` (the rounding of r2 and of k * r3), and `B^ = r2.w - k^ r3.w` has
//!
//! ```text
//! rho_B = |B^ - B| / |B| <= u (|r2.w| + 3 |k| |r3.w|) / |B|
//! ```
//!
//! which grows with the constant term of the w row, i.e. with the distance T of the model's
//! origin along the view axis (a camera 10 km away): about 4u T / n. From `n = B / (d_n - k)`
//! and `1/f = (d_f - k) / B`:
//!
//! ```text
//! |n^ - n| / n     <= rho_B + 2u |k| / |d_n - k|                  (= rho_B + 2u for [0, 1])
//! |1/f^ - 1/f|     <= (2u |k| + rho_B |d_f - k|) / |B|           (= 2u/n + rho_B/f for [0, 1])
//! ```
//!
//! The second is "the relative error of f is up to about 2u f/n (+ rho_B)", stated for 1/f so
//! that it also covers f/n beyond 1/u, where the float32 matrix is indistinguishable from an
//! infinite one (1/f^ = 0 or 1/f^ <= 2u/n), and the infinite case itself. Both are first order;
//! the tests allow a factor 1.5 and apply them when rho_n < 0.1. Beyond that the float32 matrix
//! does not determine the intended near plane, and any classification is accepted (but no
//! panic).
//!
//! Checks 2 and 3, the rewrite. The reference is the reversal, in f64, of what the float32
//! matrix renders: `lo + hi - D_fit(w)` with the fitted (k, B) (complementary), or `n^ / w`
//! (infinite; `2n^/w - 1` in [-1, 1]), at `w = r3 . v` of the pushed w row. The GPU's depth of
//! the rewritten float32 matrix on a float32 point must be within
//! [`float32_depth_floor`] of it (a rigorous bound: rounding of the new row, of the shader's
//! dot products and of the division).

mod common;

use std::cell::RefCell;

use glam::dcamera::{lh, rh};
use glam::{DMat4, DVec3, DVec4, Mat4};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use revz_math::precision::{
    float32_depth_floor, float32_ulp, gpu_clip, gpu_depth, F32_UNIT_ROUNDOFF,
};
use revz_math::{
    classify, from_rows, read_clip_transform, rewrite, write_clip_transform, Classification,
    DepthConvention, Rejection, Storage, Target, VisibleRange, E3,
};

const U: f64 = F32_UNIT_ROUNDOFF;
/// Allowance for the second-order terms of the first-order range bounds.
const FIRST_ORDER_MARGIN: f64 = 1.5;
/// Above this predicted relative error of n, the float32 matrix does not determine n.
const DETERMINED: f64 = 0.1;

// ---------------------------------------------------------------------------------------------
// Random cameras

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Composition {
    Projection,
    ProjectionView,
    ProjectionViewModel,
}

#[derive(Debug, Clone)]
struct Camera {
    fov_y: f64,
    aspect: f64,
    near: f64,
    /// `f64::INFINITY` for an infinite projection.
    far: f64,
    right_handed: bool,
    y_flip: bool,
    convention: DepthConvention,
    /// World to view.
    view: DMat4,
    /// Model to world.
    model: DMat4,
    /// Whether the camera sits 10 km from the world origin.
    far_from_origin: bool,
    composition: Composition,
    storage: Storage,
}

/// World-to-view matrix of a camera with a random orientation, either within 100 units of the
/// origin or exactly 10 km from it (seed 001's Mars case). The flag says which.
fn view_matrix() -> impl Strategy<Value = (DMat4, bool)> {
    (rotation(), unit_vector(), 0.0..100.0f64, any::<bool>()).prop_map(
        |(orientation, direction, distance, far_from_origin)| {
            let eye = direction * if far_from_origin { 1.0e4 } else { distance };
            let view = DMat4::from_quat(orientation.conjugate()) * DMat4::from_translation(-eye);
            (view, far_from_origin)
        },
    )
}

/// Model-to-world matrix: rotation, translation up to 1 km, uniform scale 0.1..10.
fn model_matrix() -> impl Strategy<Value = DMat4> {
    (
        rotation(),
        unit_vector(),
        log_uniform(1e-2, 1e3),
        log_uniform(0.1, 10.0),
    )
        .prop_map(|(orientation, direction, distance, scale)| {
            DMat4::from_scale_rotation_translation(
                DVec3::splat(scale),
                orientation,
                direction * distance,
            )
        })
}

fn convention() -> impl Strategy<Value = DepthConvention> {
    prop_oneof![
        3 => Just(DepthConvention::ZeroToOne),
        1 => Just(DepthConvention::NegativeOneToOne),
    ]
}

fn storage() -> impl Strategy<Value = Storage> {
    prop_oneof![Just(Storage::ColumnMajor), Just(Storage::RowMajor)]
}

fn composition() -> impl Strategy<Value = Composition> {
    prop_oneof![
        Just(Composition::Projection),
        Just(Composition::ProjectionView),
        Just(Composition::ProjectionViewModel),
    ]
}

/// n log-uniform in [1e-4, 10]; f log-uniform in [1.01 n, 1e9] or (one case in five) infinite.
fn near_far() -> impl Strategy<Value = (f64, f64)> {
    (log_uniform(1e-4, 10.0), 0.0..1.0f64, 0..5u8).prop_map(|(near, t, infinite)| {
        if infinite == 0 {
            return (near, f64::INFINITY);
        }
        let (lo, hi) = ((1.01 * near).ln(), 1e9f64.ln());
        (near, (lo + t * (hi - lo)).exp())
    })
}

fn camera() -> impl Strategy<Value = Camera> {
    (
        (10.0f64..120.0).prop_map(f64::to_radians),
        0.5..3.0f64,
        near_far(),
        (any::<bool>(), any::<bool>(), convention()),
        view_matrix(),
        model_matrix(),
        composition(),
        storage(),
    )
        .prop_map(
            |(
                fov_y,
                aspect,
                (near, far),
                (right_handed, y_flip, convention),
                view,
                model,
                composition,
                storage,
            )| {
                let (view, far_from_origin) = match composition {
                    Composition::Projection => (DMat4::IDENTITY, false),
                    _ => view,
                };
                let model = match composition {
                    Composition::ProjectionViewModel => model,
                    _ => DMat4::IDENTITY,
                };
                Camera {
                    fov_y,
                    aspect,
                    near,
                    far,
                    right_handed,
                    y_flip,
                    convention,
                    view,
                    model,
                    far_from_origin,
                    composition,
                    storage,
                }
            },
        )
}

// ---------------------------------------------------------------------------------------------
// Projections, independent of the crate: glam's constructors where glam has them, the formula
// of seed 001 / seed 002 otherwise.

/// Replaces the depth row of `m` by `k * r3 + b * e3`.
fn with_depth_line(m: DMat4, k: f64, b: f64) -> DMat4 {
    from_rows([m.row(0), m.row(1), k * m.row(3) + b * E3, m.row(3)])
}

/// The projection of `camera`: standard, or (for `reversed`) complementary / infinite
/// reversed.
fn projection(camera: &Camera, reversed: bool) -> DMat4 {
    let (fov, aspect, n, f) = (camera.fov_y, camera.aspect, camera.near, camera.far);
    let infinite = f == f64::INFINITY;
    let zero_to_one = camera.convention == DepthConvention::ZeroToOne;
    // glam's OpenGL modules have no infinite constructor, and glam has no complementary one:
    // swapping near and far of the finite one gives it.
    let (first, second) = if reversed { (f, n) } else { (n, f) };
    let p = match (camera.right_handed, zero_to_one, infinite, reversed) {
        (true, true, false, _) => rh::proj::directx::perspective(fov, aspect, first, second),
        (false, true, false, _) => lh::proj::directx::perspective(fov, aspect, first, second),
        (true, false, false, _) => rh::proj::opengl::perspective(fov, aspect, first, second),
        (false, false, false, _) => lh::proj::opengl::perspective(fov, aspect, first, second),
        (true, true, true, false) => rh::proj::directx::perspective_infinite(fov, aspect, n),
        (false, true, true, false) => lh::proj::directx::perspective_infinite(fov, aspect, n),
        (true, true, true, true) => rh::proj::directx::perspective_infinite_reverse(fov, aspect, n),
        (false, true, true, true) => {
            lh::proj::directx::perspective_infinite_reverse(fov, aspect, n)
        }
        (handed, false, true, reversed) => {
            let base = if handed {
                rh::proj::directx::perspective_infinite(fov, aspect, n)
            } else {
                lh::proj::directx::perspective_infinite(fov, aspect, n)
            };
            // OpenGL infinite: D = 1 - 2n/w, (k, B) = (1, -2n); reversed (-1, 2n).
            if reversed {
                with_depth_line(base, -1.0, 2.0 * n)
            } else {
                with_depth_line(base, 1.0, -2.0 * n)
            }
        }
    };
    if camera.y_flip {
        DMat4::from_scale(DVec3::new(1.0, -1.0, 1.0)) * p
    } else {
        p
    }
}

/// The true depth line (k, B) of the camera's projection (the `DESIGN.md` table).
fn true_line(camera: &Camera, reversed: bool) -> (f64, f64) {
    let (n, f) = (camera.near, camera.far);
    let (k, b) = match (camera.convention, f == f64::INFINITY) {
        (DepthConvention::ZeroToOne, false) => (f / (f - n), -f * n / (f - n)),
        (DepthConvention::ZeroToOne, true) => (1.0, -n),
        (DepthConvention::NegativeOneToOne, false) => ((f + n) / (f - n), -2.0 * f * n / (f - n)),
        (DepthConvention::NegativeOneToOne, true) => (1.0, -2.0 * n),
    };
    // Reversed: D' = lo + hi - D.
    let (lo, hi) = camera.convention.interval();
    if reversed {
        (lo + hi - k, -b)
    } else {
        (k, b)
    }
}

/// The model-view matrix (model to view space).
fn model_view(camera: &Camera) -> DMat4 {
    camera.view * camera.model
}

/// What the application pushes: the composed matrix rounded once to float32, in its storage.
fn pushed(camera: &Camera, reversed: bool) -> [f32; 16] {
    let exact = projection(camera, reversed) * model_view(camera);
    write_clip_transform(&exact, camera.storage)
}

/// A model-space point at view distance `distance`, at `(sx, sy)` in [-1, 1]^2 across the
/// frustum.
fn model_point(camera: &Camera, distance: f64, sx: f64, sy: f64) -> DVec4 {
    let half_height = (0.5 * camera.fov_y).tan() * distance;
    let z = if camera.right_handed {
        -distance
    } else {
        distance
    };
    let view_point = DVec4::new(sx * half_height * camera.aspect, sy * half_height, z, 1.0);
    model_view(camera).inverse() * view_point
}

/// `v` moved along the w row's gradient so that `w_row . v = w` (in f64).
fn onto_plane(v: DVec4, w_row: DVec4, w: f64) -> DVec4 {
    let gradient = w_row.truncate().extend(0.0);
    v + (w - w_row.dot(v)) / gradient.length_squared() * gradient
}

fn rounded(v: DVec4) -> DVec4 {
    v.as_vec4().as_dvec4()
}

/// The predicted relative error of B (module docs), from the true line and the pushed matrix.
fn rho_b(m: &DMat4, k: f64, b: f64) -> f64 {
    U * (m.row(2).w.abs() + 3.0 * k.abs() * m.row(3).w.abs()) / b.abs()
}

// ---------------------------------------------------------------------------------------------
// Statistics

use common::{check, fail, log_uniform, rotation, runner, unit_vector, Worst};

// ---------------------------------------------------------------------------------------------
// Checks 1 to 3 and 6: standard perspective cameras

/// Check 1: the recovered range is within the derived bound. Returns the classification.
fn check_range(
    camera: &Camera,
    m: &DMat4,
    worst: &mut Worst,
) -> Result<Classification, TestCaseError> {
    let classification = classify(m, camera.convention);
    let (k, b) = true_line(camera, false);
    let (lo, hi) = camera.convention.interval();
    let rho_b = rho_b(m, k, b);
    let rho_n = rho_b + 2.0 * U * k.abs() / (lo - k).abs();
    if rho_n >= DETERMINED {
        worst.count("cameras whose float32 matrix does not determine n");
        return Ok(classification);
    }
    worst.count("cameras checked");
    let Classification::Perspective {
        residual, range, ..
    } = classification
    else {
        return Err(fail(format!(
            "expected Perspective, got {classification:?}"
        )));
    };
    worst.max("fit residual", residual);
    let near_error = (range.near() / camera.near - 1.0).abs();
    worst.max("n relative error", near_error);
    worst.max("n relative error / bound", near_error / rho_n);
    if near_error > FIRST_ORDER_MARGIN * rho_n {
        return Err(fail(format!(
            "near {} recovered as {}, error {near_error:e} > bound {rho_n:e}",
            camera.near,
            range.near()
        )));
    }
    let inverse_far_bound = (2.0 * U * k.abs() + rho_b * (hi - k).abs()) / b.abs();
    let inverse_far_error = (1.0 / range.far() - 1.0 / camera.far).abs();
    worst.max(
        "|1/f^ - 1/f| / bound",
        inverse_far_error / inverse_far_bound,
    );
    if camera.far.is_finite() && inverse_far_bound * camera.far < 0.1 {
        worst.max(
            "f relative error (f/n resolvable)",
            (range.far() / camera.far - 1.0).abs(),
        );
    }
    if inverse_far_error > FIRST_ORDER_MARGIN * inverse_far_bound {
        return Err(fail(format!(
            "far {} recovered as {}, |1/f^ - 1/f| = {inverse_far_error:e} > bound \
             {inverse_far_bound:e}",
            camera.far,
            range.far()
        )));
    }
    if camera.far.is_infinite() {
        if range.is_infinite() {
            worst.count("infinite cameras recovered as infinite");
        } else {
            worst.count("infinite cameras recovered as finite f >= n/(3u)");
        }
    }
    Ok(classification)
}

/// The f64 reference of the reversed depth at `w` (independent of the crate's rewrite): the
/// fitted line reversed, `lo + hi - D_fit(w)`, or the infinite reversed `n/w` (`2n/w - 1` in
/// [-1, 1]).
fn reference_reversed_depth(
    k: f64,
    b: f64,
    range: VisibleRange,
    target: Target,
    convention: DepthConvention,
    w: f64,
) -> f64 {
    let (lo, hi) = convention.interval();
    if target == Target::Infinite || range.is_infinite() {
        lo + (hi - lo) * range.near() / w
    } else {
        // lo + hi - k first: exact for the k near 1 of a standard [0, 1] line (Sterbenz), so
        // the reference does not lose the small complementary depth near the far plane to
        // cancellation against 1.
        (lo + hi - k) - b / w
    }
}

/// Checks 2 and 3 for one target.
fn check_rewrite(
    camera: &Camera,
    m: &DMat4,
    classification: &Classification,
    target: Target,
    points: &[(f64, f64, f64)],
    worst: &mut Worst,
) -> Result<(), TestCaseError> {
    let Classification::Perspective { k, b, range, .. } = *classification else {
        return Ok(());
    };
    let Some(rewritten) = rewrite(m, classification, target) else {
        return Err(fail("a perspective matrix was not rewritten".into()));
    };
    let pushed_before = write_clip_transform(m, camera.storage);
    let pushed_after = write_clip_transform(&rewritten, camera.storage);
    let gpu_matrix = read_clip_transform(&pushed_after, camera.storage);
    // Only the depth row changes, bit for bit.
    let before = read_clip_transform(&pushed_before, camera.storage);
    for row in [0, 1, 3] {
        if gpu_matrix.row(row) != before.row(row) {
            return Err(fail(format!("row {row} changed")));
        }
    }
    let exact_row = rewritten.row(2);
    let w_row = m.row(3);
    let float32_row = gpu_matrix.row(2);
    let gpu_mat4: Mat4 = gpu_matrix.as_mat4();
    let convention = camera.convention;
    let (lo, hi) = convention.interval();
    let reference = |w: f64| reference_reversed_depth(k, b, range, target, convention, w);

    // Check 2: the planes, on points exactly on them (f64), with the float32-rounded row.
    let mut planes = vec![(range.near(), hi)];
    if range.is_infinite() || target == Target::Infinite {
        for factor in [1e3, 1e6] {
            let w = range.near() * factor;
            planes.push((w, reference(w)));
        }
    } else {
        planes.push((range.far(), lo));
    }
    for &(w, expected) in &planes {
        let (_, sx, sy) = points[0];
        let v = onto_plane(model_point(camera, camera.near, sx, sy), w_row, w);
        let w_eval = w_row.dot(v);
        let depth = float32_row.dot(v) / w_eval;
        let sum_z = (exact_row * v).abs().element_sum();
        let sum_w = (w_row * v).abs().element_sum();
        // Rounding the row once (u S_z / |w|) plus the f64 evaluation and placement.
        let bound = 1.01 * U * sum_z / w_eval.abs()
            + 16.0 * f64::EPSILON * (sum_z + sum_w * expected.abs().max(1.0)) / w_eval.abs();
        let error = (depth - expected).abs();
        if w == range.near() {
            worst.max("plane n -> hi: error / bound", error / bound);
        } else {
            worst.max("plane f (or far w) -> lo: error / bound", error / bound);
        }
        if error > bound {
            return Err(fail(format!(
                "{target:?}: depth at w = {w} is {depth}, expected {expected}, error {error:e} > \
                 {bound:e}"
            )));
        }
    }

    // Check 3: random float32 points in the frustum, float32 evaluation in shader order.
    for &(distance, sx, sy) in points {
        let v = rounded(model_point(camera, distance, sx, sy));
        let w_ref = w_row.dot(v);
        let expected = reference(w_ref);
        let floor = float32_depth_floor(exact_row, w_row, v, 0.5);
        if !floor.is_finite() {
            worst.count("points whose float32 w is lost (floor infinite)");
            continue;
        }
        let gpu = f64::from(gpu_depth(&gpu_mat4, v.as_vec4()));
        let error = (gpu - expected).abs();
        worst.max("point error / float32 floor", error / floor);
        // A bare infinite reversed P in [0, 1] has no model-view part and an exact w: its
        // floor is the rounding of n and of the division, two ulps.
        if camera.composition == Composition::Projection
            && target == Target::Infinite
            && convention == DepthConvention::ZeroToOne
        {
            let ulps = error / float32_ulp(expected);
            worst.max("infinite [0, 1] error in ulps of n/w, bare P", ulps);
            if ulps > 2.0 {
                return Err(fail(format!(
                    "bare infinite reversed depth {ulps} ulps off"
                )));
            }
        }
        if camera.far_from_origin {
            worst.max(
                "point error / float32 floor, camera 10 km away",
                error / floor,
            );
        }
        if error > floor {
            return Err(fail(format!(
                "{target:?}: depth {gpu} vs reference {expected}, error {error:e} > floor \
                 {floor:e} at {v:?}"
            )));
        }
        // The point of a = 0 (seed 001): the infinite reversed depth is within an ulp or two
        // of n over the GPU's own w, independent of the camera's distance from the origin.
        if target == Target::Infinite && convention == DepthConvention::ZeroToOne {
            let w_gpu = f64::from(gpu_clip(&gpu_mat4, v.as_vec4()).w);
            let own = range.near() / w_gpu;
            let own_ulps = (gpu - own).abs() / float32_ulp(own);
            worst.max("infinite: ulps from n / w_gpu", own_ulps);
            if own_ulps > 2.0 {
                return Err(fail(format!(
                    "infinite depth {gpu} is {own_ulps} ulps from n / w_gpu = {own}"
                )));
            }
        }
    }
    Ok(())
}

fn frustum_points(camera: &Camera) -> impl Strategy<Value = Vec<(f64, f64, f64)>> {
    let near = camera.near;
    let far = camera.far.min(1e9).max(near * 1.0001);
    let inside = (log_uniform(near, far), -1.0..1.0f64, -1.0..1.0f64);
    // Plus points at (just inside) the near and far planes.
    let at_planes = (-1.0..1.0f64, -1.0..1.0f64);
    (proptest::collection::vec(inside, 16), at_planes).prop_map(move |(mut points, (sx, sy))| {
        points.push((near * (1.0 + 1e-6), sx, sy));
        points.push((far * (1.0 - 1e-6), sy, sx));
        points
    })
}

#[test]
fn perspective_cameras_classify_recover_and_rewrite() {
    let worst = RefCell::new(Worst::default());
    let strategy = camera().prop_flat_map(|camera| {
        let points = frustum_points(&camera);
        (Just(camera), points)
    });
    check(runner(20_000).run(&strategy, |(camera, points)| {
        let pushed = pushed(&camera, false);
        let m = read_clip_transform(&pushed, camera.storage);
        let exact = projection(&camera, false) * model_view(&camera);
        prop_assert_eq!(
            m,
            exact.as_mat4().as_dmat4(),
            "read(write(m)) is the rounded m"
        );
        let mut worst = worst.borrow_mut();
        let classification = check_range(&camera, &m, &mut worst)?;
        worst.count(match classification {
            Classification::Perspective { .. } => "classified Perspective (rewritten)",
            Classification::Reversed { .. } => "classified Reversed",
            Classification::Orthographic { .. } => "classified Orthographic",
            Classification::NotProjection(_) => "classified NotProjection",
        });
        worst.count(match (camera.composition, camera.far_from_origin) {
            (Composition::Projection, _) => "composition P",
            (Composition::ProjectionView, false) => "composition P*V",
            (Composition::ProjectionView, true) => "composition P*V, camera 10 km away",
            (Composition::ProjectionViewModel, false) => "composition P*V*M",
            (Composition::ProjectionViewModel, true) => "composition P*V*M, camera 10 km away",
        });
        if camera.convention == DepthConvention::NegativeOneToOne {
            worst.count("convention [-1, 1]");
        }
        for target in [Target::Complementary, Target::Infinite] {
            check_rewrite(&camera, &m, &classification, target, &points, &mut worst)?;
        }
        Ok(())
    }));
    worst.borrow().print("perspective cameras");
}

// ---------------------------------------------------------------------------------------------
// Check 6: glam's OpenGL perspective (gluPerspective) under NegativeOneToOne

#[test]
fn opengl_matrices_recover_the_range_under_negative_one_to_one() {
    let worst = RefCell::new(Worst::default());
    let strategy = (
        (10.0f64..120.0).prop_map(f64::to_radians),
        0.5..3.0f64,
        near_far().prop_filter("finite", |(_, f)| f.is_finite()),
        any::<bool>(),
    );
    check(
        runner(2000).run(&strategy, |(fov, aspect, (n, f), right_handed)| {
            let p = if right_handed {
                rh::proj::opengl::perspective(fov, aspect, n, f)
            } else {
                lh::proj::opengl::perspective(fov, aspect, n, f)
            };
            let m = p.as_mat4().as_dmat4();
            let classification = classify(&m, DepthConvention::NegativeOneToOne);
            let Classification::Perspective { range, .. } = classification else {
                return Err(fail(format!("{classification:?}")));
            };
            // Bare P: rho_B = u, k = (f+n)/(f-n).
            let k = (f + n) / (f - n);
            let b = 2.0 * f * n / (f - n);
            let near_bound = U + 2.0 * U * k / (1.0 + k);
            let near_error = (range.near() / n - 1.0).abs();
            let inverse_far_bound = (2.0 * U * k + U * (k - 1.0)) / b;
            let inverse_far_error = (1.0 / range.far() - 1.0 / f).abs();
            let mut worst = worst.borrow_mut();
            worst.max("n relative error / bound", near_error / near_bound);
            worst.max(
                "|1/f^ - 1/f| / bound",
                inverse_far_error / inverse_far_bound,
            );
            prop_assert!(near_error <= FIRST_ORDER_MARGIN * near_bound);
            prop_assert!(inverse_far_error <= FIRST_ORDER_MARGIN * inverse_far_bound);
            // Read under the wrong convention the same matrix gives another near plane
            // (pitfall 8): D = 0 at w = 2fn/(f+n).
            if let Classification::Perspective { range: misread, .. } =
                classify(&m, DepthConvention::ZeroToOne)
            {
                prop_assert!((misread.near() / (2.0 * f * n / (f + n)) - 1.0).abs() < 1e-5);
            }
            Ok(())
        }),
    );
    worst.borrow().print("OpenGL perspective");
}

// ---------------------------------------------------------------------------------------------
// Check 4: orthographic projections

#[test]
fn orthographic_matrices_get_the_exact_finite_reversal() {
    let worst = RefCell::new(Worst::default());
    let strategy = (
        (log_uniform(0.5, 2000.0), log_uniform(0.5, 2000.0)),
        (-100.0..100.0f64, log_uniform(0.1, 1e5)),
        (any::<bool>(), convention(), storage(), composition()),
        view_matrix(),
        model_matrix(),
        proptest::collection::vec((0.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64), 16),
    );
    check(runner(5000).run(
        &strategy,
        |(
            (width, height),
            (near, depth),
            (right_handed, convention, storage, composition),
            view,
            model,
            points,
        )| {
            let far = near + depth;
            let (l, r, bottom, top) = (-0.5 * width, 0.5 * width, -0.5 * height, 0.5 * height);
            let zero_to_one = convention == DepthConvention::ZeroToOne;
            let p = match (right_handed, zero_to_one) {
                (true, true) => rh::proj::directx::orthographic(l, r, bottom, top, near, far),
                (false, true) => lh::proj::directx::orthographic(l, r, bottom, top, near, far),
                (true, false) => rh::proj::opengl::orthographic(l, r, bottom, top, near, far),
                (false, false) => lh::proj::opengl::orthographic(l, r, bottom, top, near, far),
            };
            let model_view = match composition {
                Composition::Projection => DMat4::IDENTITY,
                Composition::ProjectionView => view.0,
                Composition::ProjectionViewModel => view.0 * model,
            };
            let pushed = write_clip_transform(&(p * model_view), storage);
            let m = read_clip_transform(&pushed, storage);
            let classification = classify(&m, convention);
            prop_assert_eq!(classification, Classification::Orthographic { convention });
            let complementary = rewrite(&m, &classification, Target::Complementary);
            let infinite = rewrite(&m, &classification, Target::Infinite);
            prop_assert!(complementary.is_some());
            prop_assert_eq!(
                complementary,
                infinite,
                "orthographic never gets the infinite form"
            );
            let rewritten = complementary.unwrap_or(m);
            let gpu_matrix =
                read_clip_transform(&write_clip_transform(&rewritten, storage), storage);
            let gpu_mat4 = gpu_matrix.as_mat4();
            let (lo, hi) = convention.interval();
            let inverse_model_view = model_view.inverse();
            let mut worst = worst.borrow_mut();
            for (t, sx, sy) in points {
                let distance = near + t * depth;
                let z = if right_handed { -distance } else { distance };
                let view_point = DVec4::new(sx * 0.5 * width, sy * 0.5 * height, z, 1.0);
                let v = rounded(inverse_model_view * view_point);
                // 1 - D ([0, 1]) or -D ([-1, 1]) of what the application's matrix renders.
                let expected = lo + hi - m.row(2).dot(v) / m.row(3).dot(v);
                let floor = float32_depth_floor(rewritten.row(2), m.row(3), v, 0.5);
                let gpu = f64::from(gpu_depth(&gpu_mat4, v.as_vec4()));
                let error = (gpu - expected).abs();
                worst.max("point error / float32 floor", error / floor);
                prop_assert!(error <= floor, "error {:e} > floor {:e}", error, floor);
            }
            Ok(())
        },
    ));
    worst.borrow().print("orthographic");
}

// ---------------------------------------------------------------------------------------------
// Check 5: already reversed, model, random and non-finite matrices

#[test]
fn reversed_matrices_are_detected_and_untouched() {
    let worst = RefCell::new(Worst::default());
    check(runner(5000).run(&camera(), |camera| {
        let pushed = pushed(&camera, true);
        let m = read_clip_transform(&pushed, camera.storage);
        let classification = classify(&m, camera.convention);
        for target in [Target::Complementary, Target::Infinite] {
            prop_assert_eq!(rewrite(&m, &classification, target), None);
        }
        let (k, b) = true_line(&camera, true);
        let (lo, hi) = camera.convention.interval();
        let rho_b = rho_b(&m, k, b);
        let rho_n = rho_b + 2.0 * U * k.abs() / (hi - k).abs();
        let mut worst = worst.borrow_mut();
        if rho_n >= DETERMINED {
            worst.count("cameras whose float32 matrix does not determine n");
            return Ok(());
        }
        let Classification::Reversed { range, .. } = classification else {
            return Err(fail(format!("expected Reversed, got {classification:?}")));
        };
        if range.is_infinite() {
            worst.count("reversed recovered as infinite");
        } else {
            worst.count("reversed recovered as complementary");
        }
        let near_error = (range.near() / camera.near - 1.0).abs();
        worst.max("n relative error / bound", near_error / rho_n);
        prop_assert!(near_error <= FIRST_ORDER_MARGIN * rho_n);
        let inverse_far_bound = (2.0 * U * k.abs() + rho_b * (lo - k).abs()) / b.abs();
        let inverse_far_error = (1.0 / range.far() - 1.0 / camera.far).abs();
        worst.max(
            "|1/f^ - 1/f| / bound",
            inverse_far_error / inverse_far_bound,
        );
        prop_assert!(inverse_far_error <= FIRST_ORDER_MARGIN * inverse_far_bound);
        // glam's and our infinite reversed rows are exactly (0, 0, 0, n) * V * M = n e3.
        if camera.convention == DepthConvention::ZeroToOne && camera.far.is_infinite() {
            prop_assert!(range.is_infinite());
        }
        Ok(())
    }));
    worst.borrow().print("reversed");
}

#[test]
fn model_matrices_are_affine_and_random_matrices_are_not_projections() {
    let worst = RefCell::new(Worst::default());
    // Model matrices, possibly with non-uniform scale.
    let non_uniform = (
        rotation(),
        unit_vector(),
        log_uniform(1e-2, 1e4),
        [
            log_uniform(0.01, 100.0),
            log_uniform(0.01, 100.0),
            log_uniform(0.01, 100.0),
        ],
    );
    check(runner(2000).run(
        &(non_uniform, convention()),
        |((q, dir, dist, [sx, sy, sz]), convention)| {
            let model =
                DMat4::from_scale_rotation_translation(DVec3::new(sx, sy, sz), q, dir * dist);
            let m = model.as_mat4().as_dmat4();
            prop_assert_eq!(
                classify(&m, convention),
                Classification::Orthographic { convention }
            );
            Ok(())
        },
    ));
    // Dense random matrices: entries uniform in [-1, 1], each row scaled by 1e-3..1e3. (The
    // residual is relative to |r2.xyz|, so it is not invariant to scaling the xyz columns: a
    // matrix whose columns differ in scale by 1e5 has both rows dominated by the same column
    // and can pass with noise in the small ones. Rows of independent random directions cannot.)
    let row = (
        proptest::collection::vec(-1.0..1.0f64, 4),
        log_uniform(1e-3, 1e3),
    )
        .prop_map(|(entries, scale)| DVec4::from_slice(&entries) * scale);
    let matrix = proptest::collection::vec(row, 4)
        .prop_map(|rows| from_rows([rows[0], rows[1], rows[2], rows[3]]));
    check(runner(10_000).run(
        &(matrix, convention(), storage()),
        |(matrix, convention, storage)| {
            let m = read_clip_transform(&write_clip_transform(&matrix, storage), storage);
            let classification = classify(&m, convention);
            if let Classification::NotProjection(Rejection::DepthRowNotOnWRow { residual }) =
                classification
            {
                worst
                    .borrow_mut()
                    .max("smallest residual, inverted (1 / residual)", 1.0 / residual);
            }
            prop_assert!(
                matches!(classification, Classification::NotProjection(_)),
                "{:?}",
                classification
            );
            for target in [Target::Complementary, Target::Infinite] {
                prop_assert_eq!(rewrite(&m, &classification, target), None);
            }
            Ok(())
        },
    ));
    worst.borrow().print("random matrices");
}

#[test]
fn arbitrary_bits_never_panic_and_never_produce_non_finite_output() {
    let strategy = (
        proptest::collection::vec(any::<u32>(), 16),
        convention(),
        storage(),
    );
    check(
        runner(20_000).run(&strategy, |(bits, convention, storage)| {
            let values: [f32; 16] = std::array::from_fn(|i| f32::from_bits(bits[i]));
            let m = read_clip_transform(&values, storage);
            let classification = classify(&m, convention);
            if m.to_cols_array().iter().any(|x| !x.is_finite()) {
                prop_assert_eq!(
                    classification,
                    Classification::NotProjection(Rejection::NonFinite)
                );
            }
            for target in [Target::Complementary, Target::Infinite] {
                if let Some(rewritten) = rewrite(&m, &classification, target) {
                    let written = write_clip_transform(&rewritten, storage);
                    prop_assert!(written.iter().all(|x| x.is_finite()));
                }
            }
            Ok(())
        }),
    );
}

#[test]
fn perspective_with_a_non_finite_entry_is_not_a_projection() {
    let strategy = (
        camera(),
        0..16usize,
        prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY)],
    );
    check(runner(2000).run(&strategy, |(camera, index, bad)| {
        let mut values = pushed(&camera, false);
        values[index] = bad;
        let m = read_clip_transform(&values, camera.storage);
        let classification = classify(&m, camera.convention);
        prop_assert_eq!(
            classification,
            Classification::NotProjection(Rejection::NonFinite)
        );
        prop_assert_eq!(rewrite(&m, &classification, Target::Infinite), None);
        Ok(())
    }));
}

// ---------------------------------------------------------------------------------------------
// DESIGN.md section 1: why not r3 - r2

/// Seed 001's Mars case: terrain around the origin, the camera 10 km above it and slightly
/// rotated, the projection precomposed with the view (P*V, M = I) in float32. The complementary
/// rewrite from (k, B) against the naive reversal `r3 - r2` of the pushed rows, both compared
/// with the f64 reference `1 - D_fit(w)`.
#[test]
fn r3_minus_r2_tilts_the_depth_of_a_precomposed_matrix() {
    let (n, f) = (0.1, 1e5);
    // 10 km from the origin, looking down at the patch at an oblique angle (an axis-aligned
    // camera has exact zeros in its matrix and hides the effect, seed 001 section 5.2).
    let eye = DVec3::new(5000.0, 8000.0, 3316.6);
    let target_point = DVec3::new(150.0, 300.0, 100.0);
    let up = DVec3::Y;
    let view = rh::view::look_at_mat4(eye, target_point, up);
    let p = rh::proj::vulkan::perspective(0.6, 1.5, n, f);
    let pushed = write_clip_transform(&(p * view), Storage::ColumnMajor);
    let m = read_clip_transform(&pushed, Storage::ColumnMajor);
    let classification = classify(&m, DepthConvention::ZeroToOne);
    let Classification::Perspective { k, b, .. } = classification else {
        panic!("{classification:?}");
    };
    let by_line = rewrite(&m, &classification, Target::Complementary)
        .expect("rewritten")
        .as_mat4();
    // The naive reversal a layer could do on the pushed floats: r2' = r3 - r2, in float32.
    let pushed_rows = m.as_mat4().transpose();
    let naive = Mat4::from_cols(
        pushed_rows.x_axis,
        pushed_rows.y_axis,
        pushed_rows.w_axis - pushed_rows.z_axis,
        pushed_rows.w_axis,
    )
    .transpose();

    let exact_row = rewrite(&m, &classification, Target::Complementary)
        .expect("rewritten")
        .row(2);
    // Terrain patch: 2 km x 2 km around the origin, heights 0..600 m.
    let mut worst_line = 0.0f64;
    let mut worst_naive = 0.0f64;
    let steps = 24;
    for i in 0..=steps {
        for j in 0..=steps {
            let x = -1000.0 + 2000.0 * f64::from(i) / f64::from(steps);
            let z = -1000.0 + 2000.0 * f64::from(j) / f64::from(steps);
            let y = 600.0 * ((x * 0.003).sin() * (z * 0.002).cos()).abs();
            let v = rounded(DVec4::new(x, y, z, 1.0));
            let w = m.row(3).dot(v);
            let expected = (1.0 - k) - b / w;
            let line = f64::from(gpu_depth(&by_line, v.as_vec4()));
            let naive = f64::from(gpu_depth(&naive, v.as_vec4()));
            worst_line = worst_line.max((line / expected - 1.0).abs());
            worst_naive = worst_naive.max((naive / expected - 1.0).abs());
            let floor = float32_depth_floor(exact_row, m.row(3), v, 0.5);
            assert!((line - expected).abs() <= floor);
        }
    }
    println!(
        "camera 10 km away, P*V in float32: worst relative depth error, (k, B) rewrite \
         {worst_line:.3e}, r3 - r2 {worst_naive:.3e}, ratio {:.0}",
        worst_naive / worst_line
    );
    assert!(worst_line < 1e-6, "(k, B) rewrite error {worst_line:e}");
    assert!(
        worst_naive > 100.0 * worst_line,
        "r3 - r2 {worst_naive:e} vs (k, B) {worst_line:e}"
    );
}
