//! The rewrite: a new depth row for a standard perspective or an orthographic matrix, so that
//! the near plane maps to the top of the depth interval and the far plane to the bottom.
//!
//! Perspective (`DESIGN.md` section 1, seed 001): the new depth row is
//! `r2' = k' * r3 + B' * e3`, with (k', B') computed in f64 from the recovered range and the
//! untouched w row r3, then rounded once to float32 by [`crate::write_clip_transform`]. It is
//! not `r3 - r2`: in a precomposed P*V*M the float32 rounding already in r2 (about
//! eps * |r2|) is a large relative error in the small difference (about n/f * |r3|), a tilt of
//! the depth plane. The (k', B') form keeps only the depth line, so that tilt is dropped.
//!
//! | target | (k', B') for [0, 1] | (k', B') for [-1, 1] |
//! |---|---|---|
//! | complementary, finite f | (-n/(f-n), f*n/(f-n)) | (-(f+n)/(f-n), 2fn/(f-n)) |
//! | complementary, infinite f | (0, n) | (-1, 2n) |
//! | infinite | (0, n) | (-1, 2n) |
//!
//! Complementary is `D' = lo + hi - D` of the recovered range (`1 - D` in [0, 1], `-D` in
//! [-1, 1]); complementary of an infinite standard projection is therefore infinite reversed.
//! Infinite is `D' = n / w` in [0, 1]: its depth row `(0, 0, 0, n)` is a constant, so the depth
//! no longer depends on the rounding of the folded model-view (seed 001: "a = 0 maximises
//! arithmetic precision").
//!
//! The output is in the convention the matrix was classified under, since the layer keeps the
//! pipeline's convention. In [-1, 1] this gives `D' = -D`, which, with the viewport's window
//! transform `(D' + 1) / 2`, still loses the float-storage gain near the far plane: seed 002's
//! "Reversed OpenGL" curve. [`rewrite_into`] with [`DepthConvention::ZeroToOne`] gives the
//! [0, 1] row for a [-1, 1] input, for a layer that also turns `negativeOneToOne` off in that
//! pipeline.
//!
//! Orthographic (w constant, `DESIGN.md` pitfall 4): the exact finite reversal of the affine
//! depth, `D' = hi_out + (D - lo_in) * (lo_out - hi_out) / (hi_in - lo_in)`, i.e.
//! `r2' = alpha * r3 + beta * r2` with `beta = (lo_out - hi_out) / (hi_in - lo_in)` and
//! `alpha = hi_out - lo_in * beta`. That is `r3 - r2` (`e3 - r2` for `r3 = e3`) in [0, 1],
//! `-r2` in [-1, 1]; beta is -1 or -1/2, so every product is exact. It is the same for both
//! targets: an affine matrix never gets the infinite form. Already reversed and
//! non-projection matrices are not rewritten.

use glam::{DMat4, DVec4};

use crate::classify::Classification;
use crate::matrix::{from_rows, E3};
use crate::range::{DepthCoefficients, DepthConvention, VisibleRange};

/// Which reversed depth the rewrite produces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// Complementary Z: the same near and far planes, reversed (infinite reversed when the
    /// far plane is already at infinity).
    Complementary,
    /// Infinite reversed-Z: `D' = n / w` in [0, 1], the far plane at infinity.
    Infinite,
}

/// The reversed depth line for `range` and `target`, in `convention`.
#[must_use]
pub fn reversed_coefficients(
    range: VisibleRange,
    target: Target,
    convention: DepthConvention,
) -> DepthCoefficients {
    let reversed_range = match target {
        Target::Complementary => range,
        // VisibleRange::infinite cannot fail for the near plane of a valid range; the match
        // keeps the function total anyway.
        Target::Infinite => VisibleRange::infinite(range.near()).unwrap_or(range),
    };
    DepthCoefficients::reversed(reversed_range, convention)
}

/// Rewrites `m` to reversed depth in the convention it was classified under.
///
/// `classification` must be `classify(m, convention)`. Returns `None` (leave the matrix
/// untouched) for already reversed and non-projection matrices, and when an entry of the
/// rewritten matrix would not fit in a float32. Never panics.
#[must_use]
pub fn rewrite(m: &DMat4, classification: &Classification, target: Target) -> Option<DMat4> {
    let convention = match classification {
        Classification::Perspective { convention, .. }
        | Classification::Orthographic { convention } => *convention,
        Classification::Reversed { .. } | Classification::NotProjection(_) => return None,
    };
    rewrite_into(m, classification, target, convention)
}

/// Like [`rewrite`], with the output in `output` convention regardless of the input's.
#[must_use]
pub fn rewrite_into(
    m: &DMat4,
    classification: &Classification,
    target: Target,
    output: DepthConvention,
) -> Option<DMat4> {
    let depth_row = reversed_depth_row(m, classification, target, output)?;
    Some(from_rows([m.row(0), m.row(1), depth_row, m.row(3)]))
}

/// The depth row (r2) of [`rewrite_into`]'s result: the only row a rewrite changes, so a
/// caller holding the float32 matrix can replace just its four entries (the others stay
/// exactly as they were). `None` where [`rewrite_into`] gives `None`, including a row whose
/// entries would not fit in a float32.
#[must_use]
pub fn reversed_depth_row(
    m: &DMat4,
    classification: &Classification,
    target: Target,
    output: DepthConvention,
) -> Option<DVec4> {
    let w_row = m.row(3);
    let depth_row = match *classification {
        Classification::Perspective { range, .. } => {
            let DepthCoefficients { k, b } = reversed_coefficients(range, target, output);
            k * w_row + b * E3
        }
        Classification::Orthographic { convention } => {
            let (lo_in, hi_in) = convention.interval();
            let (lo_out, hi_out) = output.interval();
            let beta = (lo_out - hi_out) / (hi_in - lo_in);
            let alpha = hi_out - lo_in * beta;
            alpha * w_row + beta * m.row(2)
        }
        Classification::Reversed { .. } | Classification::NotProjection(_) => return None,
    };
    let fits_float32 = depth_row
        .to_array()
        .iter()
        .all(|entry| entry.is_finite() && entry.abs() <= f64::from(f32::MAX));
    fits_float32.then_some(depth_row)
}

#[cfg(test)]
mod tests {
    use glam::dcamera::{lh, rh};
    use glam::{DMat4, DVec4};

    use super::*;
    use crate::classify::classify;

    const ZERO_TO_ONE: DepthConvention = DepthConvention::ZeroToOne;
    const NEGATIVE_ONE_TO_ONE: DepthConvention = DepthConvention::NegativeOneToOne;
    const FOV: f64 = 1.2;
    const ASPECT: f64 = 16.0 / 9.0;

    fn rewritten(m: &DMat4, convention: DepthConvention, target: Target) -> DMat4 {
        let classification = classify(m, convention);
        rewrite(m, &classification, target).expect("rewritten")
    }

    #[test]
    fn complementary_of_standard_is_standard_with_planes_swapped() {
        // Exact values: n = 1, f = 5.
        for (standard, swapped) in [
            (
                rh::proj::vulkan::perspective(FOV, ASPECT, 1.0, 5.0),
                rh::proj::vulkan::perspective(FOV, ASPECT, 5.0, 1.0),
            ),
            (
                lh::proj::directx::perspective(FOV, ASPECT, 1.0, 5.0),
                lh::proj::directx::perspective(FOV, ASPECT, 5.0, 1.0),
            ),
        ] {
            let result = rewritten(&standard, ZERO_TO_ONE, Target::Complementary);
            assert_eq!(result, swapped);
        }
    }

    #[test]
    fn infinite_target_matches_glam_infinite_reverse() {
        for n in [1e-4, 0.1, 0.25, 3.0] {
            for standard in [
                rh::proj::vulkan::perspective(FOV, ASPECT, n, 1000.0),
                rh::proj::vulkan::perspective_infinite(FOV, ASPECT, n),
            ] {
                let expected = rh::proj::vulkan::perspective_infinite_reverse(FOV, ASPECT, n);
                let result = rewritten(&standard, ZERO_TO_ONE, Target::Infinite);
                assert_eq!(result.row(2), DVec4::new(0.0, 0.0, 0.0, n));
                assert!(result.abs_diff_eq(expected, 1e-15 * n), "n = {n}");
            }
        }
    }

    #[test]
    fn complementary_of_standard_infinite_is_infinite_reversed() {
        let standard = rh::proj::vulkan::perspective_infinite(FOV, ASPECT, 0.25);
        let result = rewritten(&standard, ZERO_TO_ONE, Target::Complementary);
        assert_eq!(
            result,
            rh::proj::vulkan::perspective_infinite_reverse(FOV, ASPECT, 0.25)
        );
    }

    #[test]
    fn negative_one_to_one_stays_in_its_convention() {
        let gl = rh::proj::opengl::perspective(FOV, ASPECT, 1.0, 5.0);
        let result = rewritten(&gl, NEGATIVE_ONE_TO_ONE, Target::Complementary);
        // D' = -D: the depth row is negated, the rest is untouched.
        let mut expected = gl;
        expected.z_axis.z = -gl.z_axis.z;
        expected.w_axis.z = -gl.w_axis.z;
        assert_eq!(result, expected);
        let infinite = rewritten(&gl, NEGATIVE_ONE_TO_ONE, Target::Infinite);
        // (k', B') = (-1, 2n), and r3 = (0, 0, -1, 0): r2' = (0, 0, 1, 2).
        assert_eq!(infinite.row(2), DVec4::new(0.0, 0.0, 1.0, 2.0));
    }

    #[test]
    fn negative_one_to_one_into_zero_to_one() {
        let gl = rh::proj::opengl::perspective(FOV, ASPECT, 1.0, 5.0);
        let classification = classify(&gl, NEGATIVE_ONE_TO_ONE);
        let result = rewrite_into(&gl, &classification, Target::Complementary, ZERO_TO_ONE)
            .expect("rewritten");
        // Complementary [0, 1] for (1, 5): (k', B') = (-0.25, 1.25), r3 = (0, 0, -1, 0).
        assert_eq!(result.row(2), DVec4::new(0.0, 0.0, 0.25, 1.25));
        for row in [0, 1, 3] {
            assert_eq!(result.row(row), gl.row(row));
        }
    }

    #[test]
    fn orthographic_gets_the_exact_finite_reversal_for_both_targets() {
        let ortho = rh::proj::vulkan::orthographic(-2.0, 2.0, -1.0, 1.0, 0.5, 8.5);
        let depth_row = ortho.row(2);
        for target in [Target::Complementary, Target::Infinite] {
            let result = rewritten(&ortho, ZERO_TO_ONE, target);
            assert_eq!(result.row(2), E3 - depth_row);
            assert_eq!(result.row(3), E3);
        }
        let gl_ortho = rh::proj::opengl::orthographic(-2.0, 2.0, -1.0, 1.0, 0.5, 8.5);
        let result = rewritten(&gl_ortho, NEGATIVE_ONE_TO_ONE, Target::Infinite);
        assert_eq!(result.row(2), -gl_ortho.row(2));
        // [-1, 1] into [0, 1]: D' = (1 - D) / 2.
        let classification = classify(&gl_ortho, NEGATIVE_ONE_TO_ONE);
        let into_vulkan = rewrite_into(
            &gl_ortho,
            &classification,
            Target::Complementary,
            ZERO_TO_ONE,
        )
        .expect("rewritten");
        assert_eq!(into_vulkan.row(2), 0.5 * (E3 - gl_ortho.row(2)));
    }

    #[test]
    fn reversed_and_non_projections_are_untouched() {
        let reversed = rh::proj::vulkan::perspective_infinite_reverse(FOV, ASPECT, 0.1);
        let random = DMat4::from_cols_array(&std::array::from_fn(|i| (i as f64 * 0.37).sin()));
        for m in [reversed, random, DMat4::ZERO, DMat4::NAN] {
            for target in [Target::Complementary, Target::Infinite] {
                let classification = classify(&m, ZERO_TO_ONE);
                assert_eq!(
                    rewrite(&m, &classification, target),
                    None,
                    "{classification:?}"
                );
            }
        }
    }

    #[test]
    fn result_beyond_float32_is_refused() {
        // n = 1, f = 1.01: k = 101, B = -101, and the complementary k' = -100. With a w row
        // at half of f32::MAX, k' * r3 does not fit in a float32.
        let big = f64::from(f32::MAX) / 2.0;
        let m = crate::matrix::from_rows([
            DVec4::X,
            DVec4::Y,
            DVec4::new(0.0, 0.0, -101.0 * big, -101.0),
            DVec4::new(0.0, 0.0, -big, 0.0),
        ]);
        let classification = classify(&m, ZERO_TO_ONE);
        let range = classification.range().expect("perspective");
        assert!((range.near() - 1.0).abs() < 1e-12 && (range.far() - 1.01).abs() < 1e-12);
        assert_eq!(rewrite(&m, &classification, Target::Complementary), None);
        // The infinite row (0, 0, 0, n) fits.
        assert!(rewrite(&m, &classification, Target::Infinite).is_some());
    }
}
