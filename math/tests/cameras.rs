//! Property tests of the camera table (`revz_math::camera`): the error bounds of `DepthLine`
//! against the application's true (k, B), and the table's grouping of matrices into cameras.
//!
//! Matrices are built the way applications build them: `P * V * Model` composed in f64 and
//! rounded once to float32, or composed in float32 with glam's `Mat4` (f32 projection
//! constructors, `(P * V) * Model` as glam's `P * V * M` evaluates it, and `P * (V * Model)`).
//! The true line is that of the projection's parameters as the application passed them (the f32
//! values for the float32 compositions). Every check prints the worst ratio it saw
//! (`cargo test -p revz-math --test cameras -- --nocapture`); `PROPTEST_RNG_SEED` pins a seed.
//!
//! The float32 `(P * V) * Model` composition is only checked against the bounds with the eye
//! within the nearest object's view distance of the world origin (the module docs' limitation);
//! `float32_view_translation_beyond_the_bound_is_measured` shows what happens beyond.

mod common;

use std::cell::RefCell;

use glam::{camera, dcamera, DMat4, DQuat, DVec3, DVec4, Mat4};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use revz_math::precision::F32_UNIT_ROUNDOFF;
use revz_math::{
    classify, from_rows, CameraMatch, Cameras, Classification, DepthConvention, DepthDirection,
    DepthLine, AFFINE_W_TOLERANCE, E3, MAX_CAMERAS, TRUSTED_B_ERROR,
};

const U: f64 = F32_UNIT_ROUNDOFF;
const ZERO_TO_ONE: DepthConvention = DepthConvention::ZeroToOne;
const NEGATIVE_ONE_TO_ONE: DepthConvention = DepthConvention::NegativeOneToOne;

// ---------------------------------------------------------------------------------------------
// Statistics (as in tests/properties.rs)

use common::{check, fail, log_uniform, rotation, runner, unit_vector, Worst};

// ---------------------------------------------------------------------------------------------
// Cameras and objects

/// How the application composes `P * V * Model`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Composition {
    /// In f64, rounded once to float32.
    F64,
    /// glam `Mat4`: `(P * V) * Model` (what `p * v * m` evaluates).
    F32ProjectionViewFirst,
    /// glam `Mat4`: `P * (V * Model)`.
    F32ModelViewFirst,
}

fn composition() -> impl Strategy<Value = Composition> {
    prop_oneof![
        Just(Composition::F64),
        Just(Composition::F32ProjectionViewFirst),
        Just(Composition::F32ModelViewFirst),
    ]
}

#[derive(Debug, Clone, Copy)]
struct Lens {
    fov_y: f64,
    aspect: f64,
    near: f64,
    /// `f64::INFINITY` for an infinite projection.
    far: f64,
    convention: DepthConvention,
}

impl Lens {
    /// The parameters as the application passes them: f64, or rounded to f32 for a float32
    /// composition (the true line is that of these values).
    fn as_passed(&self, composition: Composition) -> Self {
        if composition == Composition::F64 {
            return *self;
        }
        let round = |x: f64| f64::from(x as f32);
        Self {
            fov_y: round(self.fov_y),
            aspect: round(self.aspect),
            near: round(self.near),
            far: if self.far.is_infinite() {
                self.far
            } else {
                round(self.far)
            },
            convention: self.convention,
        }
    }

    /// The true depth line (`DESIGN.md` table) of the parameters.
    fn true_line(&self) -> (f64, f64) {
        let (n, f) = (self.near, self.far);
        match (self.convention, f.is_infinite()) {
            (ZERO_TO_ONE, false) => (f / (f - n), -f * n / (f - n)),
            (ZERO_TO_ONE, true) => (1.0, -n),
            (NEGATIVE_ONE_TO_ONE, false) => ((f + n) / (f - n), -2.0 * f * n / (f - n)),
            (NEGATIVE_ONE_TO_ONE, true) => (1.0, -2.0 * n),
        }
    }

    /// glam's right-handed Vulkan (Y-down, [0, 1]) or OpenGL ([-1, 1]) projection in f64.
    /// glam has no OpenGL infinite constructor: the Vulkan one with the depth row
    /// `(k, B) = (1, -2n)`.
    fn projection_f64(&self) -> DMat4 {
        let (fov, aspect, n, f) = (self.fov_y, self.aspect, self.near, self.far);
        match (self.convention, f.is_infinite()) {
            (ZERO_TO_ONE, false) => dcamera::rh::proj::vulkan::perspective(fov, aspect, n, f),
            (ZERO_TO_ONE, true) => dcamera::rh::proj::vulkan::perspective_infinite(fov, aspect, n),
            (NEGATIVE_ONE_TO_ONE, false) => {
                dcamera::rh::proj::opengl::perspective(fov, aspect, n, f)
            }
            (NEGATIVE_ONE_TO_ONE, true) => {
                let p = dcamera::rh::proj::vulkan::perspective_infinite(fov, aspect, n);
                from_rows([p.row(0), p.row(1), p.row(3) - 2.0 * n * E3, p.row(3)])
            }
        }
    }

    /// The same in float32, with glam's f32 constructors (their own rounding included).
    fn projection_f32(&self) -> Mat4 {
        let (fov, aspect, n, f) = (
            self.fov_y as f32,
            self.aspect as f32,
            self.near as f32,
            self.far as f32,
        );
        match (self.convention, self.far.is_infinite()) {
            (ZERO_TO_ONE, false) => camera::rh::proj::vulkan::perspective(fov, aspect, n, f),
            (ZERO_TO_ONE, true) => camera::rh::proj::vulkan::perspective_infinite(fov, aspect, n),
            (NEGATIVE_ONE_TO_ONE, false) => {
                camera::rh::proj::opengl::perspective(fov, aspect, n, f)
            }
            (NEGATIVE_ONE_TO_ONE, true) => {
                let mut p = camera::rh::proj::vulkan::perspective_infinite(fov, aspect, n);
                // Column 3's z is the depth row's w entry: -2n (exact in f32).
                p.w_axis.z = -2.0 * n;
                p
            }
        }
    }
}

/// n log-uniform in [1e-4, 10]; f/n log-uniform in [10, 1e9] or (one case in five) infinite.
fn lens() -> impl Strategy<Value = Lens> {
    (
        (10.0f64..120.0).prop_map(f64::to_radians),
        0.5..3.0f64,
        log_uniform(1e-4, 10.0),
        log_uniform(10.0, 1e9),
        0..5u8,
        prop_oneof![3 => Just(ZERO_TO_ONE), 1 => Just(NEGATIVE_ONE_TO_ONE)],
    )
        .prop_map(|(fov_y, aspect, near, ratio, infinite, convention)| Lens {
            fov_y,
            aspect,
            near,
            far: if infinite == 0 {
                f64::INFINITY
            } else {
                near * ratio
            },
            convention,
        })
}

/// Where the camera is: orientation and eye (never at the origin).
#[derive(Debug, Clone, Copy)]
struct Pose {
    orientation: DQuat,
    eye: DVec3,
}

impl Pose {
    fn view(&self) -> DMat4 {
        DMat4::from_quat(self.orientation.conjugate()) * DMat4::from_translation(-self.eye)
    }
}

/// An object: view distance of its origin, lateral offset within the frustum, rotation, scale.
#[derive(Debug, Clone, Copy)]
struct Object {
    /// The origin's view distance, in units of n.
    distance: f64,
    lateral: (f64, f64),
    rotation: DQuat,
    scale: f64,
}

fn object(distances: (f64, f64)) -> impl Strategy<Value = Object> {
    (
        log_uniform(distances.0, distances.1),
        (-0.5..0.5f64, -0.5..0.5f64),
        rotation(),
        log_uniform(0.1, 10.0),
    )
        .prop_map(|(distance, lateral, rotation, scale)| Object {
            distance,
            lateral,
            rotation,
            scale,
        })
}

/// The model matrix of `object` for a camera at `pose` with near plane `near`: its origin is
/// `distance * near` ahead along the view direction (offset sideways within the frustum).
fn model_matrix(object: &Object, pose: &Pose, near: f64) -> DMat4 {
    let d = object.distance * near;
    let (sx, sy) = object.lateral;
    let q = pose.orientation;
    let position = pose.eye + q * DVec3::new(sx * d, sy * d, -d);
    DMat4::from_scale_rotation_translation(DVec3::splat(object.scale), object.rotation, position)
}

/// What the application pushes for `object`, as f64 values of the float32 matrix.
fn pushed(lens: &Lens, pose: &Pose, object: &Object, composition: Composition) -> DMat4 {
    let lens = lens.as_passed(composition);
    let view = pose.view();
    let model = model_matrix(object, pose, lens.near);
    match composition {
        Composition::F64 => (lens.projection_f64() * view * model).as_mat4().as_dmat4(),
        Composition::F32ProjectionViewFirst => {
            (lens.projection_f32() * view.as_mat4() * model.as_mat4()).as_dmat4()
        }
        Composition::F32ModelViewFirst => {
            (lens.projection_f32() * (view.as_mat4() * model.as_mat4())).as_dmat4()
        }
    }
}

/// Whether w does not vary in `m` (classify's affine test): such a matrix has no line.
fn is_affine(m: &DMat4) -> bool {
    m.row(3).truncate().length() <= AFFINE_W_TOLERANCE * m.row(3).w.abs()
}

/// Checks the line of `m` against the true one; `None` (and no check) for an affine `m`.
fn checked_line(
    m: &DMat4,
    truth: (f64, f64),
    worst: &mut Worst,
    (b_label, k_label): (&'static str, &'static str),
) -> Result<Option<DepthLine>, TestCaseError> {
    let Some(line) = DepthLine::of(m) else {
        if !is_affine(m) {
            return Err(fail(format!("no line for a non-affine matrix {m:?}")));
        }
        worst.count("affine (object tiny against its distance)");
        return Ok(None);
    };
    let (k, b) = truth;
    let k_ratio = (line.k - k).abs() / line.k_error;
    let b_ratio = (line.b - b).abs() / line.b_error;
    worst.max(b_label, b_ratio);
    worst.max(k_label, k_ratio);
    if k_ratio > 1.0 || b_ratio > 1.0 {
        return Err(fail(format!(
            "bound violated: k {} vs true {k} (error bound {}), b {} vs true {b} (bound {})",
            line.k, line.k_error, line.b, line.b_error
        )));
    }
    Ok(Some(line))
}

fn labels(composition: Composition) -> (&'static str, &'static str) {
    match composition {
        Composition::F64 => (
            "|B^ - B| / b_error, f64 once rounded",
            "|k^ - k| / k_error, f64 once rounded",
        ),
        Composition::F32ProjectionViewFirst => (
            "|B^ - B| / b_error, f32 (P*V)*M, |eye| <= d_min",
            "|k^ - k| / k_error, f32 (P*V)*M, |eye| <= d_min",
        ),
        Composition::F32ModelViewFirst => (
            "|B^ - B| / b_error, f32 P*(V*M)",
            "|k^ - k| / k_error, f32 P*(V*M)",
        ),
    }
}

/// A camera, its objects (the first one within 50 n: trusted), and an order to observe them.
#[derive(Debug, Clone)]
struct Scene {
    lens: Lens,
    pose: Pose,
    composition: Composition,
    objects: Vec<Object>,
    order: Vec<usize>,
}

fn scene() -> impl Strategy<Value = Scene> {
    (
        lens(),
        rotation(),
        unit_vector(),
        log_uniform(1e-3, 1.0),
        log_uniform(1e-2, 1e6),
        composition(),
        object((10.0, 50.0)),
        proptest::collection::vec(object((10.0, 1e6)), 9),
        proptest::collection::vec(any::<u32>(), 10),
    )
        .prop_map(
            |(
                lens,
                orientation,
                direction,
                eye_fraction,
                eye_far,
                composition,
                first,
                rest,
                keys,
            )| {
                let mut objects = vec![first];
                objects.extend(rest);
                // The eye's distance from the world origin, in units of n: anywhere up to 1e6 n,
                // but for float32 (P * V) * Model within the nearest object's distance (module
                // docs' limitation).
                let eye_distance = if composition == Composition::F32ProjectionViewFirst {
                    let nearest = objects.iter().map(|o| o.distance).fold(f64::MAX, f64::min);
                    eye_fraction * nearest
                } else {
                    eye_far
                };
                let pose = Pose {
                    orientation,
                    eye: direction * eye_distance * lens.near,
                };
                let mut order: Vec<usize> = (0..objects.len()).collect();
                order.sort_by_key(|&i| keys[i]);
                Scene {
                    lens,
                    pose,
                    composition,
                    objects,
                    order,
                }
            },
        )
}

// ---------------------------------------------------------------------------------------------
// 1. Bounds, one camera for all its matrices, the range of the best line

#[test]
fn matrices_of_one_camera_land_on_one_camera_with_the_true_range() {
    let worst = RefCell::new(Worst::default());
    check(runner(400).run(&scene(), |scene| {
        let worst = &mut *worst.borrow_mut();
        let truth_lens = scene.lens.as_passed(scene.composition);
        let truth = truth_lens.true_line();
        let convention = scene.lens.convention;
        let mut lines = Vec::new();
        for object in &scene.objects {
            let m = pushed(&scene.lens, &scene.pose, object, scene.composition);
            let line = checked_line(&m, truth, worst, labels(scene.composition))?;
            if let Some(line) = line {
                worst.max(
                    "relative_b_error of a line (object at <= 1e6 n)",
                    line.relative_b_error().min(1e300),
                );
                if line.b == 0.0 {
                    worst.count("lines with B exactly 0");
                }
            }
            lines.push((m, line));
        }
        let first = lines.first().and_then(|(_, line)| *line);
        if !first.is_some_and(|line| line.is_trusted()) {
            return Err(fail(format!(
                "the nearest-placed object is not trusted: {first:?}"
            )));
        }
        let mut cameras = Cameras::new();
        let mut camera_index = None;
        for &i in &scene.order {
            let (m, line) = &lines[i];
            let result = cameras.observe(m, convention);
            match (result, line, camera_index) {
                (CameraMatch::NotPerspective, None, _) => {}
                (CameraMatch::Untrusted, Some(line), None)
                    if !line.is_trusted() && !provisional(line, convention) =>
                {
                    worst.count("untrusted before the camera is known");
                }
                (CameraMatch::Camera { index, .. }, Some(line), None)
                    if line.is_trusted() || provisional(line, convention) =>
                {
                    if !line.is_trusted() {
                        worst.count("provisional cameras from untrusted standard lines");
                    }
                    camera_index = Some(index);
                }
                (CameraMatch::Camera { index, .. }, Some(_), Some(known)) if index == known => {}
                (result, line, known) => {
                    return Err(fail(format!(
                        "object {i}: {result:?} for {line:?}, camera so far {known:?}"
                    )));
                }
            }
        }
        let Some(index) = camera_index else {
            return Err(fail("no camera".into()));
        };
        prop_assert_eq!(cameras.len(), 1);
        // Every matrix again, in the original order: the same camera, nothing changes.
        for (m, line) in &lines {
            let result = cameras.observe(m, convention);
            if line.is_some() {
                let CameraMatch::Camera {
                    index: again,
                    changed,
                    ..
                } = result
                else {
                    return Err(fail(format!("{result:?} after the camera is known")));
                };
                prop_assert_eq!(again, index);
                prop_assert!(!changed);
            }
        }
        // The camera's line is the best one seen, and its near plane is the true one within
        // that line's relative error of B.
        let (range, direction, stored_convention, best) =
            cameras.camera(index).expect("the camera exists");
        prop_assert_eq!(direction, DepthDirection::Standard);
        prop_assert_eq!(stored_convention, convention);
        let best_seen = lines
            .iter()
            .filter_map(|(_, line)| *line)
            .map(|line| line.relative_b_error())
            .fold(f64::INFINITY, f64::min);
        prop_assert_eq!(best.relative_b_error(), best_seen);
        let near_error = (range.near() / truth_lens.near - 1.0).abs();
        worst.max(
            "camera's |n^/n - 1| / best relative_b_error",
            near_error / best.relative_b_error(),
        );
        worst.max("camera's |n^/n - 1|", near_error);
        prop_assert!(
            near_error <= best.relative_b_error(),
            "near {} vs true {}: error {near_error:e} > {:e}",
            range.near(),
            truth_lens.near,
            best.relative_b_error()
        );
        Ok(())
    }));
    worst.borrow().print("one camera, one range");
}

/// The limitation of the module docs, measured: float32 `(P * V) * Model` with the eye far from
/// the world origin compared with the object's view distance d. Prints the worst ratio
/// `|B^ - B| / b_error` per decade of `|eye| / d`; asserts only that the bound holds below
/// `|eye| = d`, so that a change in the bounds shows here.
#[test]
fn float32_view_translation_beyond_the_bound_is_measured() {
    const NAMES: [&str; 6] = [
        "|eye|/d in [1e-3, 1e-2)",
        "|eye|/d in [1e-2, 1e-1)",
        "|eye|/d in [1e-1, 1)",
        "|eye|/d in [1, 10)",
        "|eye|/d in [10, 100)",
        "|eye|/d in [100, 1e3)",
    ];
    let worst = RefCell::new(Worst::default());
    for name in NAMES {
        worst.borrow_mut().max(name, 0.0);
    }
    let strategy = (
        lens(),
        rotation(),
        unit_vector(),
        object((10.0, 1e4)),
        -3.0..3.0f64,
    );
    check(runner(3000).run(
        &strategy,
        |(lens, orientation, direction, object, decade)| {
            let pose = Pose {
                orientation,
                eye: direction * object.distance * lens.near * 10f64.powf(decade),
            };
            let m = pushed(&lens, &pose, &object, Composition::F32ProjectionViewFirst);
            let Some(line) = DepthLine::of(&m) else {
                return Ok(());
            };
            let (_, b) = lens
                .as_passed(Composition::F32ProjectionViewFirst)
                .true_line();
            let ratio = (line.b - b).abs() / line.b_error;
            let bucket = ((decade + 3.0).floor() as usize).min(NAMES.len() - 1);
            worst.borrow_mut().max(NAMES[bucket], ratio);
            if decade < 0.0 {
                prop_assert!(ratio <= 1.0, "ratio {ratio} at |eye|/d = 1e{decade}");
            }
            Ok(())
        },
    ));
    worst
        .borrow()
        .print("float32 (P*V)*M, |B^ - B| / b_error by |eye| / d");
}

// ---------------------------------------------------------------------------------------------
// 2. Different cameras stay apart

/// Observes every `(camera, matrix)` pair and checks that each camera gets one index of its own.
fn check_separate(
    cameras: &mut Cameras,
    observations: &[(usize, DMat4, DepthConvention)],
    count: usize,
) -> Result<(), TestCaseError> {
    let mut indices = vec![None; count];
    for (camera, m, convention) in observations {
        let result = cameras.observe(m, *convention);
        let CameraMatch::Camera { index, .. } = result else {
            return Err(fail(format!(
                "camera {camera}: {result:?} for a trusted matrix"
            )));
        };
        match indices[*camera] {
            None => indices[*camera] = Some(index),
            Some(known) if known == index => {}
            Some(known) => {
                return Err(fail(format!(
                    "camera {camera} on {index}, earlier on {known}"
                )));
            }
        }
    }
    for (a, index_a) in indices.iter().enumerate() {
        for (b, index_b) in indices.iter().enumerate().skip(a + 1) {
            if index_a.is_some() && index_a == index_b {
                return Err(fail(format!("cameras {a} and {b} share index {index_a:?}")));
            }
        }
    }
    Ok(())
}

#[test]
fn cameras_whose_near_or_far_differ_stay_apart() {
    let worst = RefCell::new(Worst::default());
    let strategy = (
        lens(),
        log_uniform(1.01, 100.0),
        any::<bool>(),
        log_uniform(10.0, 1e9),
        0..3u8,
        (rotation(), unit_vector(), log_uniform(1e-2, 1e3)),
        proptest::collection::vec((0..2usize, object((10.0, 100.0)), composition()), 12),
    );
    check(runner(300).run(
        &strategy,
        |(first, factor, down, far_ratio, variant, (orientation, direction, eye), objects)| {
            // Variant 0: n differs by `factor`, f independent. 1: the same n, f differs by a
            // factor >= 2 with f <= 1e4 n, so that k differs by more than n / (2f) >= 5e-5.
            // 2: n differs, the same f/n.
            let mut second = first;
            let n_factor = if down { 1.0 / factor } else { factor };
            match variant {
                0 => {
                    second.near = first.near * n_factor;
                    second.far = if far_ratio > 1e8 {
                        f64::INFINITY
                    } else {
                        second.near * far_ratio
                    };
                }
                1 => {
                    let first_far = first.near * far_ratio.min(1e4);
                    let mut first = first;
                    first.far = first_far;
                    second.far = first_far * (2.0 + factor);
                    worst.borrow_mut().count("pairs with the same n, f apart");
                    return check_pair(&first, &second, orientation, direction, eye, &objects);
                }
                _ => {
                    second.near = first.near * n_factor;
                    second.far = first.far * n_factor;
                }
            }
            worst.borrow_mut().count(if variant == 0 {
                "pairs with n apart, f independent"
            } else {
                "pairs with n apart, the same f/n"
            });
            check_pair(&first, &second, orientation, direction, eye, &objects)
        },
    ));
    worst.borrow().print("two cameras");
}

fn check_pair(
    first: &Lens,
    second: &Lens,
    orientation: DQuat,
    direction: DVec3,
    eye: f64,
    objects: &[(usize, Object, Composition)],
) -> Result<(), TestCaseError> {
    let lenses = [first, second];
    let observations: Vec<_> = objects
        .iter()
        .map(|&(camera, object, composition)| {
            let lens = lenses[camera];
            // (P * V) * Model in float32 only with the eye near the origin (limitation).
            let eye_distance = if composition == Composition::F32ProjectionViewFirst {
                1.0
            } else {
                eye
            };
            let pose = Pose {
                orientation,
                eye: direction * eye_distance * lens.near,
            };
            let m = pushed(lens, &pose, &object, composition);
            (camera, m, lens.convention)
        })
        .collect();
    for (_, m, _) in &observations {
        let line = DepthLine::of(m);
        prop_assert!(line.is_some_and(|line| line.is_trusted()), "{line:?}");
    }
    check_separate(&mut Cameras::new(), &observations, 2)
}

/// Shadow-cascade-like views of one main camera: consecutive slices, and nested ones that share
/// the near plane (only k tells them apart), interleaved with the main camera.
#[test]
fn cascade_cameras_stay_separate() {
    let slices = [(0.1, 5.0), (5.0, 20.0), (20.0, 80.0), (80.0, 300.0)];
    let nested = [(0.1, 1e4), (0.1, 5.0), (0.1, 20.0), (0.1, 80.0)];
    let strategy = (
        rotation(),
        unit_vector(),
        proptest::collection::vec((0..4usize, object((1.5, 4.0)), composition()), 24),
    );
    for planes in [slices, nested] {
        for convention in [ZERO_TO_ONE, NEGATIVE_ONE_TO_ONE] {
            check(
                runner(64).run(&strategy, |(orientation, direction, objects)| {
                    let lenses = planes.map(|(near, far)| Lens {
                        fov_y: 1.0,
                        aspect: 16.0 / 9.0,
                        near,
                        far,
                        convention,
                    });
                    let pose = Pose {
                        orientation,
                        eye: direction * 0.05,
                    };
                    let observations: Vec<_> = objects
                        .iter()
                        .map(|&(camera, object, composition)| {
                            let lens = &lenses[camera];
                            // The object 1.5 to 4 near planes ahead: well inside every slice's
                            // trust (d / n <= 4).
                            (
                                camera,
                                pushed(lens, &pose, &object, composition),
                                convention,
                            )
                        })
                        .collect();
                    check_separate(&mut Cameras::new(), &observations, planes.len())
                }),
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 3. Far first

#[test]
fn a_far_matrix_before_the_camera_is_untrusted_and_borrows_its_range_after() {
    let strategy = (
        lens(),
        rotation(),
        unit_vector(),
        composition(),
        object((2e6, 1e8)),
        object((10.0, 30.0)),
    );
    check(runner(300).run(
        &strategy,
        |(lens, orientation, direction, composition, far, near)| {
            let pose = Pose {
                orientation,
                eye: direction * 5.0 * lens.near,
            };
            let far_m = pushed(&lens, &pose, &far, composition);
            let near_m = pushed(&lens, &pose, &near, composition);
            if DepthLine::of(&far_m).is_none() {
                // Affine (a small object very far away): not perspective, nothing to learn.
                prop_assert_eq!(
                    Cameras::new().observe(&far_m, lens.convention),
                    CameraMatch::NotPerspective
                );
                return Ok(());
            }
            let far_line = DepthLine::of(&far_m).expect("checked above");
            prop_assert!(!far_line.is_trusted());
            let mut cameras = Cameras::new();
            let convention = lens.convention;
            // Alone, the far line is refused, or (standard direction) a provisional camera.
            let first = cameras.observe(&far_m, convention);
            if provisional(&far_line, convention) {
                prop_assert!(
                    matches!(first, CameraMatch::Camera { changed: true, .. }),
                    "{:?}",
                    first
                );
            } else {
                prop_assert_eq!(first, CameraMatch::Untrusted);
                prop_assert!(cameras.is_empty());
            }
            // The near matrix starts the camera, or replaces the provisional line.
            let CameraMatch::Camera {
                index,
                range,
                direction,
                changed: true,
            } = cameras.observe(&near_m, convention)
            else {
                return Err(fail("the near matrix starts no camera".into()));
            };
            prop_assert_eq!(cameras.len(), 1);
            prop_assert_eq!(
                cameras.observe(&far_m, convention),
                CameraMatch::Camera {
                    index,
                    range,
                    direction,
                    changed: false
                }
            );
            // Another convention is another camera: the far matrix alone is untrusted there.
            let other = match convention {
                ZERO_TO_ONE => NEGATIVE_ONE_TO_ONE,
                NEGATIVE_ONE_TO_ONE => ZERO_TO_ONE,
            };
            let alone = cameras.observe(&far_m, other);
            prop_assert!(
                alone == CameraMatch::Untrusted
                    || matches!(alone, CameraMatch::Camera { index: i, .. } if i != index),
                "{:?}",
                alone
            );
            Ok(())
        },
    ));
}

/// Whether an untrusted `line` starts a provisional camera: its computed range is a valid
/// standard perspective (`revz_math::camera`, "Trust").
fn provisional(line: &DepthLine, convention: DepthConvention) -> bool {
    matches!(
        line.coefficients().visible_range(convention),
        Ok((DepthDirection::Standard, _))
    )
}

// ---------------------------------------------------------------------------------------------
// 4. Not perspective, never a panic

#[test]
fn affine_orthographic_and_garbage_are_not_perspective() {
    let affine = (
        rotation(),
        unit_vector(),
        log_uniform(1e-2, 1e4),
        [
            log_uniform(0.01, 100.0),
            log_uniform(0.01, 100.0),
            log_uniform(0.01, 100.0),
        ],
        (0.1..10.0f64, 0.1..10.0f64, 1e-2..1.0f64, 1.0..1e4f64),
        0..4usize,
        (0..16usize, prop_oneof![Just(f64::NAN), Just(f64::INFINITY)]),
    );
    check(runner(2000).run(
        &affine,
        |(q, dir, dist, [sx, sy, sz], (width, height, near, far), kind, (entry, bad))| {
            let model =
                DMat4::from_scale_rotation_translation(DVec3::new(sx, sy, sz), q, dir * dist);
            let ortho = dcamera::rh::proj::vulkan::orthographic(
                -width,
                width,
                -height,
                height,
                near,
                near + far,
            );
            let perspective = dcamera::rh::proj::vulkan::perspective(1.0, 1.5, near, near + far);
            let m = match kind {
                0 => model,
                1 => ortho * model,
                2 => {
                    let mut values = (perspective * model).to_cols_array();
                    values[entry] = bad;
                    DMat4::from_cols_array(&values)
                }
                _ => {
                    let m = perspective * model;
                    from_rows([m.row(0), m.row(1), m.row(2), DVec4::ZERO])
                }
            };
            let m = m.as_mat4().as_dmat4();
            for convention in [ZERO_TO_ONE, NEGATIVE_ONE_TO_ONE] {
                let mut cameras = Cameras::new();
                prop_assert_eq!(cameras.observe(&m, convention), CameraMatch::NotPerspective);
                prop_assert!(cameras.is_empty());
                let classification = classify(&m, convention);
                let perspective = matches!(
                    classification,
                    Classification::Perspective { .. } | Classification::Reversed { .. }
                );
                prop_assert!(!perspective, "{:?}", classification);
            }
            Ok(())
        },
    ));
}

#[test]
fn arbitrary_bits_never_panic() {
    let special = prop_oneof![
        any::<u32>().prop_map(f32::from_bits),
        Just(0.0f32),
        Just(-0.0f32),
        Just(1.0f32),
        Just(-1.0f32),
        Just(f32::MIN_POSITIVE),
        Just(f32::from_bits(1)),
        Just(f32::MAX),
        Just(f32::MIN),
        Just(f32::INFINITY),
        Just(f32::NAN),
    ];
    let strategy = (
        proptest::collection::vec(special, 16),
        prop_oneof![Just(ZERO_TO_ONE), Just(NEGATIVE_ONE_TO_ONE)],
    );
    // One table across all cases, so that matches against cameras started by garbage run too.
    let cameras = RefCell::new(Cameras::new());
    let worst = RefCell::new(Worst::default());
    check(runner(20_000).run(&strategy, |(values, convention)| {
        let values: [f32; 16] = std::array::from_fn(|i| values[i]);
        let m = DMat4::from_cols_array(&values.map(f64::from));
        let mut cameras = cameras.borrow_mut();
        let result = cameras.observe(&m, convention);
        let line = DepthLine::of(&m);
        prop_assert_eq!(line.is_none(), result == CameraMatch::NotPerspective);
        if !m.is_finite() {
            prop_assert_eq!(result, CameraMatch::NotPerspective);
        }
        let name = match result {
            CameraMatch::Camera { index, range, .. } => {
                prop_assert!(index < MAX_CAMERAS);
                prop_assert!(0.0 < range.near() && range.near() < range.far());
                let (stored, ..) = cameras.camera(index).expect("a camera");
                prop_assert_eq!(stored, range);
                "camera"
            }
            CameraMatch::Untrusted => "untrusted",
            CameraMatch::NotPerspective => "not perspective",
        };
        worst.borrow_mut().count(name);
        let mut merged = cameras.clone();
        merged.merge(&cameras);
        prop_assert_eq!(merged.len(), cameras.len());
        Ok(())
    }));
    worst.borrow().print("arbitrary bits");
}

// ---------------------------------------------------------------------------------------------
// 5. Merge and eviction

fn vulkan_lens(near: f64, far: f64) -> Lens {
    Lens {
        fov_y: 1.0,
        aspect: 1.5,
        near,
        far,
        convention: ZERO_TO_ONE,
    }
}

fn plain_object(distance: f64) -> Object {
    Object {
        distance,
        lateral: (0.1, -0.2),
        rotation: DQuat::from_rotation_y(0.4),
        scale: 1.0,
    }
}

fn plain_pose() -> Pose {
    Pose {
        orientation: DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 0.3),
        eye: DVec3::new(1.0, -2.0, 0.5),
    }
}

fn plain_matrix(lens: &Lens, distance: f64) -> DMat4 {
    pushed(
        lens,
        &plain_pose(),
        &plain_object(distance),
        Composition::F64,
    )
}

/// A recording's table (`Cameras::pinning_ranges`): every matrix of a camera gets the range of
/// the camera's first trusted line, whichever order the objects come in, while the table's line
/// becomes the best one, which a merge into the device's (plain) table hands on with its range.
#[test]
fn a_pinning_table_keeps_the_first_trusted_range_and_learns_the_best_line() {
    let lens = vulkan_lens(0.1, 1000.0);
    let distances = [400.0, 3.0, 60.0, 0.5, 900.0];
    let matrices: Vec<DMat4> = distances.iter().map(|&d| plain_matrix(&lens, d)).collect();
    let mut pinned = Cameras::new().pinning_ranges();
    let mut plain = Cameras::new();
    let ranges: Vec<_> = matrices
        .iter()
        .map(|m| {
            plain.observe(m, ZERO_TO_ONE);
            match pinned.observe(m, ZERO_TO_ONE) {
                CameraMatch::Camera { range, .. } => range,
                other => panic!("a camera: {other:?}"),
            }
        })
        .collect();
    let first = DepthLine::of(&matrices[0]).expect("a line");
    assert!(first.is_trusted());
    assert!(ranges.iter().all(|r| *r == ranges[0]), "{ranges:?}");
    // The range of the first line, not the best one.
    let best = plain.camera(0).expect("a camera");
    assert_ne!(ranges[0], best.0, "the first line is not the best here");
    assert_eq!(
        pinned.camera(0).expect("a camera").3,
        best.3,
        "the best line"
    );
    // The device's table, merging the recording's, gets the best range.
    let mut device = Cameras::new();
    assert!(device.merge(&pinned));
    assert_eq!(device.camera(0).expect("a camera").0, best.0);
    // A recording adopting the camera another met first gets that one's range, and keeps it.
    let mut other = Cameras::new().pinning_ranges();
    let slot = other.adopt(&pinned, 0, None).expect("adopted");
    let CameraMatch::Camera { index, range, .. } = other.observe(&matrices[3], ZERO_TO_ONE) else {
        panic!("a camera");
    };
    assert_eq!((index, range), (slot, ranges[0]));
    assert_eq!(other.adopt(&pinned, MAX_CAMERAS, None), None);
    assert_eq!(other.adopt(&pinned, 0, Some(MAX_CAMERAS)), None);
}

/// An untrusted first line (B lost to rounding) is provisional even in a pinning table: the
/// first trusted line replaces its range, and pins it from then on.
#[test]
fn a_pinning_table_replaces_a_provisional_range() {
    let lens = vulkan_lens(0.01, 1.0e7);
    let far = plain_matrix(&lens, 1.0e6 * 0.01 * 50.0);
    let far_line = DepthLine::of(&far).expect("a line");
    assert!(!far_line.is_trusted(), "{}", far_line.relative_b_error());
    let mut pinned = Cameras::new().pinning_ranges();
    let CameraMatch::Camera {
        range: provisional, ..
    } = pinned.observe(&far, ZERO_TO_ONE)
    else {
        panic!("a provisional camera");
    };
    let (near, nearer) = (plain_matrix(&lens, 5.0), plain_matrix(&lens, 0.1));
    let CameraMatch::Camera { range: trusted, .. } = pinned.observe(&near, ZERO_TO_ONE) else {
        panic!("the camera");
    };
    assert_ne!(provisional, trusted);
    let CameraMatch::Camera {
        range: kept,
        changed,
        ..
    } = pinned.observe(&nearer, ZERO_TO_ONE)
    else {
        panic!("the camera");
    };
    assert!(changed, "a better line");
    assert_eq!(kept, trusted, "pinned at the first trusted line");
}

#[test]
fn merge_keeps_the_better_line_and_adds_unknown_cameras() {
    let lens = vulkan_lens(0.1, 1000.0);
    let (near, farther) = (plain_matrix(&lens, 12.0), plain_matrix(&lens, 400.0));
    let near_line = DepthLine::of(&near).expect("a line");
    let farther_line = DepthLine::of(&farther).expect("a line");
    // 400 n: trusted, but with about 24u * 400 = 6e-4 of relative error, 30 times the near one's.
    assert!(farther_line.relative_b_error() <= TRUSTED_B_ERROR);
    assert!(near_line.relative_b_error() < farther_line.relative_b_error());

    let mut coarse = Cameras::new();
    let mut fine = Cameras::new();
    assert!(matches!(
        coarse.observe(&farther, ZERO_TO_ONE),
        CameraMatch::Camera { .. }
    ));
    assert!(matches!(
        fine.observe(&near, ZERO_TO_ONE),
        CameraMatch::Camera { .. }
    ));
    // A second camera only `fine` knows.
    let other = vulkan_lens(0.5, 100.0);
    let CameraMatch::Camera {
        index: other_index, ..
    } = fine.observe(&plain_matrix(&other, 20.0), ZERO_TO_ONE)
    else {
        panic!("a camera");
    };

    let mut merged = coarse.clone();
    assert!(merged.merge(&fine));
    assert_eq!(merged.len(), 2);
    let CameraMatch::Camera {
        index,
        changed: false,
        ..
    } = merged.observe(&farther, ZERO_TO_ONE)
    else {
        panic!("a known camera");
    };
    assert_eq!(merged.camera(index).expect("a camera").3, near_line);
    assert_eq!(
        merged.camera(index).map(|camera| camera.0),
        fine.camera(0).map(|camera| camera.0)
    );
    let other_range = fine.camera(other_index).expect("a camera").0;
    let CameraMatch::Camera { range, .. } =
        merged.observe(&plain_matrix(&other, 30.0), ZERO_TO_ONE)
    else {
        panic!("the added camera");
    };
    assert_eq!(range, other_range);
    // Nothing new the second time; and the better table keeps its line.
    assert!(!merged.merge(&fine));
    let mut fine_again = fine.clone();
    assert!(!fine_again.merge(&coarse));
    assert_eq!(fine_again.camera(0).expect("a camera").3, near_line);
    merged.clear();
    assert!(merged.is_empty());
}

#[test]
fn the_least_recently_used_camera_is_evicted() {
    // MAX_CAMERAS + 1 cameras whose n differ by 1.5x.
    let lenses: Vec<Lens> = (0..=MAX_CAMERAS)
        .map(|i| vulkan_lens(0.01 * 1.5f64.powi(i as i32), 1e4))
        .collect();
    let observe = |cameras: &mut Cameras, camera: usize| match cameras
        .observe(&plain_matrix(&lenses[camera], 20.0), ZERO_TO_ONE)
    {
        CameraMatch::Camera { index, changed, .. } => (index, changed),
        other => panic!("{other:?}"),
    };
    let mut cameras = Cameras::new();
    let indices: Vec<usize> = (0..MAX_CAMERAS)
        .map(|i| observe(&mut cameras, i).0)
        .collect();
    assert_eq!(cameras.len(), MAX_CAMERAS);
    // Camera 0 used again: camera 1 is now the least recently used, and the new one takes its
    // slot.
    assert_eq!(observe(&mut cameras, 0), (indices[0], false));
    assert_eq!(observe(&mut cameras, MAX_CAMERAS), (indices[1], true));
    assert_eq!(cameras.len(), MAX_CAMERAS);
    // Camera 1 comes back as a new camera in the slot of camera 2 (now the oldest).
    assert_eq!(observe(&mut cameras, 1), (indices[2], true));
    for camera in [0, 3, MAX_CAMERAS] {
        assert!(!observe(&mut cameras, camera).1, "camera {camera} was kept");
    }

    // Merging into a full table evicts the least recently used as well.
    let mut newer = Cameras::new();
    observe(&mut newer, 2);
    assert!(cameras.merge(&newer));
    assert_eq!(cameras.len(), MAX_CAMERAS);
    assert!(!observe(&mut cameras, 2).1);
}

/// A line that agrees with two cameras belongs to the most recently used of them.
#[test]
fn a_line_agreeing_with_two_cameras_belongs_to_the_most_recently_used() {
    // Two trusted lines of one k, their B apart by more than both bounds; a third between
    // them, within both.
    let line = |b: f64| DepthLine {
        k: 1.001,
        b,
        k_error: 1e-6,
        b_error: 0.01,
    };
    let mut cameras = Cameras::new();
    let index_of = |m: CameraMatch| match m {
        CameraMatch::Camera { index, .. } => index,
        other => panic!("{other:?}"),
    };
    let first = index_of(cameras.observe_line(line(-0.10), ZERO_TO_ONE));
    let second = index_of(cameras.observe_line(line(-0.13), ZERO_TO_ONE));
    assert_ne!(first, second);
    let between = line(-0.115);
    assert_eq!(cameras.find(&between, ZERO_TO_ONE), Some(second));
    cameras.touch(first);
    assert_eq!(cameras.find(&between, ZERO_TO_ONE), Some(first));
    // Five more cameras leave one free slot, which the next takes; then the least recently
    // used (`second`) makes room.
    for i in 0..MAX_CAMERAS - 3 {
        index_of(cameras.observe_line(line(-1.0 - i as f64), ZERO_TO_ONE));
    }
    assert_eq!(cameras.len(), MAX_CAMERAS - 1);
    let last = index_of(cameras.observe_line(line(-50.0), ZERO_TO_ONE));
    assert_eq!(cameras.len(), MAX_CAMERAS);
    assert!(![first, second].contains(&last));
    assert_eq!(
        index_of(cameras.observe_line(line(-60.0), ZERO_TO_ONE)),
        second
    );
}

// ---------------------------------------------------------------------------------------------
// 6. The deep-range scene

/// The `deep-range` camera (tester `accuracy::scenes::deep_range`): at the origin looking down
/// -z, slightly rotated, n = 1e-3, f = 1e7, fov 50 deg, aspect 4/3; a backdrop and a plate at
/// every decade of view distance from 1e-2 to 1e6, composed in f64 and rounded once.
#[test]
fn deep_range_gets_one_camera_with_the_true_near_plane() {
    let (near, far) = (1e-3, 1e7);
    let view = dcamera::rh::view::look_at_mat4(
        DVec3::ZERO,
        DVec3::new(0.031, -0.017, -1.0),
        DVec3::new(0.05, 1.0, 0.0),
    );
    let fov_y = 50f64.to_radians();
    let aspect = 4.0 / 3.0;
    let projection = dcamera::rh::proj::vulkan::perspective(fov_y, aspect, near, far);
    let view_to_world = view.inverse();
    let t = (fov_y / 2.0).tan();
    let distances = [1e-2, 1e-1, 1.0, 10.0, 1e2, 1e3, 1e4, 1e5, 1e6];
    let mut matrices = Vec::new();
    for (i, &d) in distances.iter().enumerate() {
        let (cx, cy) = ((i % 3) as f64 - 1.0, (i / 3) as f64 - 1.0);
        let center = DVec3::new(cx * 2.0 / 3.0 * t * aspect * d, -cy * 2.0 / 3.0 * t * d, -d);
        let frame = view_to_world
            * DMat4::from_translation(center)
            * DMat4::from_rotation_y(0.3)
            * DMat4::from_rotation_x(0.2);
        let plate = frame * DMat4::from_translation(DVec3::new(0.0, 0.0, 0.01 * d));
        for model in [frame, plate] {
            matrices.push((projection * view * model).as_mat4().as_dmat4());
        }
    }
    // The far cells have lost B to rounding: B exactly 0 at some distance.
    let lines: Vec<DepthLine> = matrices
        .iter()
        .map(|m| DepthLine::of(m).expect("every cell is perspective"))
        .collect();
    assert!(lines.iter().any(|line| line.b == 0.0));
    let true_b = -far * near / (far - near);
    for line in &lines {
        assert!((line.b - true_b).abs() <= line.b_error, "{line:?}");
    }

    let nearest_first: Vec<usize> = (0..matrices.len()).collect();
    let farthest_first: Vec<usize> = nearest_first.iter().rev().copied().collect();
    for order in [nearest_first, farthest_first] {
        let mut cameras = Cameras::new();
        let mut camera = None;
        for &i in &order {
            let result = cameras.observe(&matrices[i], ZERO_TO_ONE);
            match (result, camera) {
                (CameraMatch::Untrusted, None) => assert!(!lines[i].is_trusted()),
                (CameraMatch::Camera { index, .. }, None) => camera = Some(index),
                (CameraMatch::Camera { index, .. }, Some(known)) => assert_eq!(index, known),
                (result, _) => panic!("cell {i}: {result:?}"),
            }
        }
        let index = camera.expect("a camera");
        assert_eq!(cameras.len(), 1);
        for m in &matrices {
            let CameraMatch::Camera {
                index: again,
                range,
                changed: false,
                ..
            } = cameras.observe(m, ZERO_TO_ONE)
            else {
                panic!("not the camera");
            };
            assert_eq!(again, index);
            assert!(
                (range.near() / near - 1.0).abs() < 1e-5,
                "n = {}",
                range.near()
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Small exact cases

#[test]
fn bare_projection_lines() {
    // n = 1, f = 5: k = 1.25, B = -1.25 exactly.
    let m = dcamera::rh::proj::vulkan::perspective(1.0, 1.5, 1.0, 5.0);
    let line = DepthLine::of(&m).expect("a line");
    assert_eq!((line.k, line.b), (1.25, -1.25));
    assert_eq!(line.k_error, 8.0 * U * 1.25);
    // r2.w = -1.25, r3.w = 0.
    assert_eq!(line.b_error, 8.0 * U * 1.25);
    assert!(line.is_trusted() && line.agrees_with(&line));
    // A line with B = 0 is never trusted.
    let constant = from_rows([DVec4::X, DVec4::Y, 0.5 * -DVec4::Z, -DVec4::Z]);
    let line = DepthLine::of(&constant).expect("a line");
    assert_eq!(line.b, 0.0);
    assert_eq!(line.relative_b_error(), f64::INFINITY);
    assert!(!line.is_trusted());
    assert_eq!(
        Cameras::new().observe(&constant, ZERO_TO_ONE),
        CameraMatch::Untrusted
    );
    // A precise line without a valid range (everything behind the camera) starts no camera.
    let behind = from_rows([
        DVec4::X,
        DVec4::Y,
        DVec4::new(0.0, 0.0, 1.0, -1.0),
        -DVec4::Z,
    ]);
    assert!(DepthLine::of(&behind).is_some_and(|line| line.is_trusted()));
    assert_eq!(
        Cameras::new().observe(&behind, ZERO_TO_ONE),
        CameraMatch::Untrusted
    );
    // Already reversed: a camera of reversed direction.
    let reversed = dcamera::rh::proj::vulkan::perspective_infinite_reverse(1.0, 1.5, 0.25);
    let CameraMatch::Camera {
        direction, range, ..
    } = Cameras::new().observe(&reversed, ZERO_TO_ONE)
    else {
        panic!("a camera");
    };
    assert_eq!(direction, DepthDirection::Reversed);
    assert_eq!(range.near(), 0.25);
    assert!(range.is_infinite());
}

// ---------------------------------------------------------------------------------------------
// The per-push reading of a stored matrix

/// A float32 entry: mostly ordinary values of any magnitude, sometimes zero, an infinity or NaN.
fn entry() -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -1e6f32..1e6f32,
        2 => -2.0f32..2.0f32,
        1 => Just(0.0f32),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NAN),
    ]
}

proptest! {
    /// `DepthLine::of_stored` reads only the depth and w rows, and gives the very line (the same
    /// bits, the same `None`s) `DepthLine::of` gives for the whole matrix.
    #[test]
    fn the_line_of_stored_values_is_the_line_of_the_matrix_they_store(
        values in prop::array::uniform16(entry()),
        row_major in any::<bool>(),
        projection in any::<bool>(),
    ) {
        let mut values = values;
        if projection {
            // A perspective-shaped w row, so that lines (not only `None`s) are compared.
            values[3] = 0.0;
            values[7] = 0.0;
            values[11] = -1.0;
            values[15] = 0.0;
        }
        let storage = if row_major { revz_math::Storage::RowMajor } else { revz_math::Storage::ColumnMajor };
        let whole = DepthLine::of(&revz_math::read_clip_transform(&values, storage));
        let rows = DepthLine::of_stored(&values, storage);
        prop_assert_eq!(whole.map(|l| (l.k.to_bits(), l.b.to_bits(), l.k_error.to_bits(), l.b_error.to_bits())),
            rows.map(|l| (l.k.to_bits(), l.b.to_bits(), l.k_error.to_bits(), l.b_error.to_bits())));
    }
}

#[test]
fn a_stored_perspective_has_the_line_of_its_matrix() {
    let m = dcamera::rh::proj::vulkan::perspective(1.0, 1.5, 0.5, 50.0)
        * DMat4::from_translation(DVec3::new(0.3, -2.0, -7.0));
    let values = m.as_mat4().to_cols_array();
    let line = DepthLine::of_stored(&values, revz_math::Storage::ColumnMajor)
        .expect("a perspective has a line");
    let whole = DepthLine::of(&revz_math::read_clip_transform(
        &values,
        revz_math::Storage::ColumnMajor,
    ));
    assert_eq!(Some(line), whole);
    let transposed = m.transpose().as_mat4().to_cols_array();
    assert_eq!(
        DepthLine::of_stored(&transposed, revz_math::Storage::RowMajor),
        whole
    );
}

// ---------------------------------------------------------------------------------------------
// The same-camera shortcut's test without the line

/// What the same-camera shortcut needs of `values` against the camera's `line`, computed the
/// long way (the line, then the comparisons).
fn holds_exactly(line: &DepthLine, values: &[f32; 16], storage: revz_math::Storage) -> bool {
    DepthLine::of_stored(values, storage).is_some_and(|own| {
        line.agrees_with(&own) && own.relative_b_error() >= line.relative_b_error()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// `surely_holds` never says yes where the long way says no: for one camera's P * V * M
    /// (objects near and far, rounded once or composed in float32), and for the same entries
    /// perturbed.
    #[test]
    fn surely_holds_implies_what_the_line_says(
        near in 0.01f64..10.0,
        far_over_near in 10.0f64..1e6,
        fovy in 0.3f64..2.0,
        eye in prop::array::uniform3(-1e3f64..1e3),
        target in prop::array::uniform3(-1e3f64..1e3),
        camera_object in prop::array::uniform3(-50.0f64..50.0),
        object in prop::array::uniform3(-1e4f64..1e4),
        nudge in 0usize..48,
        row_major in any::<bool>(),
    ) {
        let projection = dcamera::rh::proj::vulkan::perspective(fovy, 1.5, near, near * far_over_near);
        let (eye, target) = (DVec3::from(eye), DVec3::from(target));
        prop_assume!((target - eye).length() > 1e-3);
        let view = dcamera::rh::view::look_at_mat4(eye, target, DVec3::Y);
        let store = |m: DMat4| {
            if row_major { m.transpose().as_mat4().to_cols_array() } else { m.as_mat4().to_cols_array() }
        };
        let storage = if row_major { revz_math::Storage::RowMajor } else { revz_math::Storage::ColumnMajor };
        // The camera's line: its first object, near the eye.
        let first = store(projection * view * DMat4::from_translation(eye + DVec3::from(camera_object)));
        let Some(line) = DepthLine::of_stored(&first, storage) else { return Ok(()) };
        let mut values = store(projection * view * DMat4::from_translation(DVec3::from(object)));
        let exact = holds_exactly(&line, &values, storage);
        if line.surely_holds(&values, storage) {
            prop_assert!(exact, "surely_holds said yes, the line says no: {values:?} against {line:?}");
        }
        // One entry nudged by a few ulps or by a lot: still never a yes that is wrong.
        let (index, scale) = (nudge % 16, [1.0 + 4.0 * f32::EPSILON, 1.001, 2.0][nudge / 16]);
        values[index] *= scale;
        if line.surely_holds(&values, storage) {
            prop_assert!(holds_exactly(&line, &values, storage), "nudged {index} by {scale}: {values:?}");
        }
    }
}

/// The shortcut is worth having: for one camera's objects farther than the one whose line it
/// keeps (what most of a frame's pushes are), `surely_holds` says yes for almost all of those
/// the long way accepts.
#[test]
fn surely_holds_accepts_most_of_one_cameras_matrices() {
    let projection = dcamera::rh::proj::vulkan::perspective(1.0, 1.5, 0.1, 1000.0);
    let eye = DVec3::new(3.0, 2.0, 10.0);
    let view = dcamera::rh::view::look_at_mat4(eye, DVec3::ZERO, DVec3::Y);
    let line = DepthLine::of_stored(
        &(projection * view * DMat4::from_translation(eye * 0.9))
            .as_mat4()
            .to_cols_array(),
        revz_math::Storage::ColumnMajor,
    )
    .unwrap();
    let (mut exact, mut sure) = (0, 0);
    for i in 0..10_000 {
        let t = i as f64;
        let object = DVec3::new(
            (t * 0.37).sin() * 40.0,
            (t * 0.11).cos() * 5.0,
            -(t % 97.0) * 3.0,
        );
        let values = (projection * view * DMat4::from_translation(object))
            .as_mat4()
            .to_cols_array();
        let long_way = holds_exactly(&line, &values, revz_math::Storage::ColumnMajor);
        let short = line.surely_holds(&values, revz_math::Storage::ColumnMajor);
        assert!(!short || long_way);
        exact += usize::from(long_way);
        sure += usize::from(short);
    }
    println!("surely_holds: {sure} of the {exact} matrices the line accepts");
    assert!(
        exact > 9_000,
        "the test's matrices are the camera's: {exact}"
    );
    assert!(sure * 10 >= exact * 9, "{sure} of {exact}");
}

/// Near the line's own object (where "does not improve it" is decided by a hair), in float32
/// compositions too: `surely_holds` still never says a wrong yes.
#[test]
fn surely_holds_is_never_wrong_near_the_cameras_best_object() {
    let (mut exact, mut sure) = (0, 0);
    for camera in 0..20 {
        let c = f64::from(camera);
        let (near, far) = (0.05 + c * 0.07, 100.0 + c * 500.0);
        let eye = DVec3::new(c * 3.0 - 20.0, 1.0 + c, 15.0 - c);
        let projection = dcamera::rh::proj::vulkan::perspective(0.9, 1.6, near, far);
        let view = dcamera::rh::view::look_at_mat4(eye, DVec3::ZERO, DVec3::Y);
        let best = eye * 0.8;
        let line = DepthLine::of_stored(
            &(projection * view * DMat4::from_translation(best))
                .as_mat4()
                .to_cols_array(),
            revz_math::Storage::ColumnMajor,
        )
        .unwrap();
        let (p32, v32) = (projection.as_mat4(), view.as_mat4());
        for i in 0..5_000 {
            let t = f64::from(i);
            // Around the best object's distance from the eye: 0.5x to 2x, in every direction.
            let scale = 0.5 + 1.5 * ((t * 0.618_033_988_7) % 1.0);
            let direction = DVec3::new((t * 1.3).sin(), (t * 0.7).cos(), (t * 0.29).sin()) * 0.05;
            let object = eye + (best - eye + direction) * scale;
            let values = match i % 3 {
                0 => (projection * view * DMat4::from_translation(object))
                    .as_mat4()
                    .to_cols_array(),
                1 => (p32 * v32 * Mat4::from_translation(object.as_vec3())).to_cols_array(),
                _ => (p32 * (v32 * Mat4::from_translation(object.as_vec3()))).to_cols_array(),
            };
            let long_way = holds_exactly(&line, &values, revz_math::Storage::ColumnMajor);
            let short = line.surely_holds(&values, revz_math::Storage::ColumnMajor);
            assert!(
                !short || long_way,
                "camera {camera}, object {i}: {values:?}"
            );
            exact += usize::from(long_way);
            sure += usize::from(short);
        }
    }
    println!("near the best object: surely_holds {sure} of the {exact} the line accepts");
    assert!(sure > 0 && exact < 100_000);
}
