//! Property tests of the fit a rewritten vertex stage evaluates (`revz_math::shader_fit`):
//! its error against the f64 fit of the same float32 entries (`DepthLine::of`), the bound the
//! module docs derive, what it gives a bare or shared projection (the near plane within a few
//! u), and how far apart the ranges of per-object precomposed matrices of one camera are,
//! measured in units of the flip path's own rounding at the same distance.
//!
//! Matrices are `P * V * Model` composed in f64 and rounded once to float32, as the tester's
//! buffer scenes hand them to the shader. `cargo test -p revz-math --test shader_fit --
//! --nocapture` prints the worst ratios.

mod common;

use std::cell::RefCell;

use glam::{dcamera, DMat4, DVec3, DVec4};
use proptest::prelude::*;
use revz_math::precision::F32_UNIT_ROUNDOFF;
use revz_math::shader_fit::{depth_and_w_rows, fit_in_shader, ShaderLine};
use revz_math::DepthLine;

use common::{check, fail, log_uniform, rotation, runner, unit_vector, Worst};

const U: f64 = F32_UNIT_ROUNDOFF;

#[derive(Debug, Clone, Copy)]
struct Setup {
    fov_y: f64,
    near: f64,
    /// `f64::INFINITY` for an infinite projection.
    far: f64,
    eye: DVec3,
    /// Unit direction the camera looks along.
    forward: DVec3,
    /// The object's origin's distance along the view axis, in near-plane distances.
    object_distance: f64,
    object_rotation: glam::DQuat,
    object_scale: f64,
}

fn setup() -> impl Strategy<Value = Setup> {
    (
        0.3..2.0f64,
        log_uniform(1e-3, 10.0),
        prop_oneof![log_uniform(10.0, 1e7), Just(f64::INFINITY)],
        (unit_vector(), log_uniform(1e-3, 1e4)),
        unit_vector(),
        log_uniform(10.0, 1e6),
        rotation(),
        log_uniform(0.1, 10.0),
    )
        .prop_map(
            |(fov_y, near, ratio, (eye_dir, eye_distance), forward, d, object_rotation, s)| Setup {
                fov_y,
                near,
                far: near * ratio,
                eye: eye_dir * eye_distance * near,
                forward,
                object_distance: d,
                object_rotation,
                object_scale: s,
            },
        )
}

impl Setup {
    fn projection(&self) -> DMat4 {
        if self.far.is_infinite() {
            dcamera::rh::proj::vulkan::perspective_infinite(self.fov_y, 1.5, self.near)
        } else {
            dcamera::rh::proj::vulkan::perspective(self.fov_y, 1.5, self.near, self.far)
        }
    }

    fn view(&self) -> DMat4 {
        let up = if self.forward.y.abs() > 0.9 {
            DVec3::X
        } else {
            DVec3::Y
        };
        dcamera::rh::view::look_at_mat4(self.eye, self.eye + self.forward, up)
    }

    fn model(&self) -> DMat4 {
        let origin = self.eye + self.forward * self.object_distance * self.near;
        DMat4::from_scale_rotation_translation(
            DVec3::splat(self.object_scale),
            self.object_rotation,
            origin,
        )
    }

    /// The true line (k, B) of the projection.
    fn true_line(&self) -> (f64, f64) {
        let (n, f) = (self.near, self.far);
        if f.is_infinite() {
            (1.0, -n)
        } else {
            (f / (f - n), -f * n / (f - n))
        }
    }
}

/// The matrix rounded once to float32, its shader rows, and the f64 values of those entries.
fn rounded(m: DMat4) -> (([f32; 4], [f32; 4]), DMat4) {
    let single = m.as_mat4();
    (
        depth_and_w_rows(&single.to_cols_array_2d(), false),
        single.as_dmat4(),
    )
}

/// The float32 fit's B and near plane.
fn near_of(line: ShaderLine) -> f64 {
    f64::from(-line.b / line.k)
}

#[test]
fn the_float32_fit_is_within_its_bound_of_the_f64_fit_of_the_same_entries() {
    let worst = RefCell::new(Worst::default());
    let result = runner(4000).run(&setup(), |s| {
        let m = s.projection() * s.view() * s.model();
        let ((a, b), entries) = rounded(m);
        let Some(line64) = DepthLine::of(&entries) else {
            // The f64 fit refuses: the shader must not accept a line the CPU would not call
            // a projection (it may refuse more: its comparisons are float32).
            if let Some(line) = fit_in_shader(a, b) {
                return Err(fail(format!(
                    "accepted {line:?} where DepthLine refuses: {s:?}"
                )));
            }
            worst.borrow_mut().count("refused by both");
            return Ok(());
        };
        let Some(line) = fit_in_shader(a, b) else {
            if line64.b < 0.0 && line64.k > 0.0 && line64.relative_b_error() < 1e-3 {
                return Err(fail(format!(
                    "refused a well-conditioned line {line64:?}: {s:?}"
                )));
            }
            worst.borrow_mut().count("refused by the shader only");
            return Ok(());
        };
        let (aw, kbw) = (f64::from(a[3]).abs(), (line64.k * f64::from(b[3])).abs());
        let bound = 10.0 * U * (aw + kbw);
        let k_error = (f64::from(line.k) - line64.k).abs() / line64.k.abs();
        let b_error = (f64::from(line.b) - line64.b).abs();
        worst
            .borrow_mut()
            .max("|k32 - k64| / (u |k64|)", k_error / U);
        worst
            .borrow_mut()
            .max("|B32 - B64| / bound", b_error / bound);
        if k_error > 8.5 * U || b_error > bound {
            return Err(fail(format!(
                "k error {k_error:e}, B error {b_error:e} > bound {bound:e}: {s:?}"
            )));
        }
        Ok(())
    });
    worst.borrow().print("float32 fit against the f64 fit");
    check(result);
}

#[test]
fn a_shared_projection_gives_its_near_plane_within_a_few_u() {
    // The bare P (a block with projection, view and model: the outermost factor is P), and
    // P * V of a camera within 1e4 n of the origin (a view-projection beside model matrices).
    let worst = RefCell::new(Worst::default());
    let result = runner(2000).run(&setup(), |s| {
        let n = s.near;
        for (name, m, limit) in [
            ("P", s.projection(), 4.0 * U),
            ("P * V", s.projection() * s.view(), 0.0),
        ] {
            let ((a, b), entries) = rounded(m);
            let line = fit_in_shader(a, b).ok_or_else(|| fail(format!("{name} refused: {s:?}")))?;
            let relative = (near_of(line) / n - 1.0).abs();
            if name == "P" {
                worst.borrow_mut().max("P: |n32 / n - 1| / u", relative / U);
                if relative > limit {
                    return Err(fail(format!("{name}: near off by {relative:e}: {s:?}")));
                }
            } else {
                // P * V: B carries the view translation's rounding (about u |k| |eye| / n
                // relative); the f64 fit of the same entries says how much.
                let line64 = DepthLine::of(&entries).expect("a projection");
                let bound = line64.relative_b_error() + 10.0 * U * (1.0 + s.eye.length() / n);
                worst
                    .borrow_mut()
                    .max("P * V: |n32 / n - 1| / bound", relative / bound);
                if relative > bound {
                    return Err(fail(format!("{name}: near off by {relative:e}: {s:?}")));
                }
            }
        }
        Ok(())
    });
    worst.borrow().print("shared projections");
    check(result);
}

#[test]
fn per_object_ranges_differ_by_a_few_units_of_the_flip_paths_rounding() {
    // Two objects of one camera at the same distance d, each with its own precomposed float32
    // P * V * M: the relative difference of their fitted near planes is the relative depth
    // error between them. The flip path's stored 1 - D rounds D near 1 to u, a relative error
    // of about u d / n in the reversed depth n / d: the unit of this measurement.
    let worst = RefCell::new(Worst::default());
    let result = runner(3000).run(&(setup(), rotation()), |(s, other_rotation)| {
        let other = Setup {
            object_rotation: other_rotation,
            ..s
        };
        let fit = |setup: &Setup| {
            let ((a, b), _) = rounded(setup.projection() * setup.view() * setup.model());
            fit_in_shader(a, b)
        };
        let (Some(first), Some(second)) = (fit(&s), fit(&other)) else {
            worst.borrow_mut().count("one refused (flip mapping)");
            return Ok(());
        };
        let spread = (near_of(first) / near_of(second) - 1.0).abs();
        let unit = U * s.object_distance;
        worst
            .borrow_mut()
            .max("|n1 / n2 - 1| / (u d / n)", spread / unit);
        if spread > 16.0 * unit {
            return Err(fail(format!(
                "ranges {spread:e} apart, unit {unit:e}: {s:?}"
            )));
        }
        let (k, b) = s.true_line();
        let truth = -b / k;
        worst.borrow_mut().max(
            "|n1 / n - 1| / (u d / n)",
            (near_of(first) / truth - 1.0).abs() / unit,
        );
        Ok(())
    });
    worst.borrow().print("per-object ranges");
    check(result);
}

#[test]
fn the_flip_mapping_is_what_a_refused_fit_stores() {
    // An orthographic matrix and one with a NaN are refused; an affine-looking P * V * M (the
    // object 1e7 n away in a unit-scale model) too, as `DepthLine::of` refuses it.
    let ortho = dcamera::rh::proj::vulkan::orthographic(-1.0, 1.0, -1.0, 1.0, 0.1, 100.0);
    let ((a, b), _) = rounded(ortho);
    assert_eq!(fit_in_shader(a, b), None);
    let mut nan = DMat4::IDENTITY;
    nan.w_axis = DVec4::new(f64::NAN, 0.0, 0.0, 1.0);
    let ((a, b), _) = rounded(nan);
    assert_eq!(fit_in_shader(a, b), None);
}
