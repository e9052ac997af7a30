//! The range a rewritten vertex stage derives from the matrix it loads (issue #16): the
//! float32 fit that revz's SPIR-V evaluates per vertex where the layer cannot read the
//! projection on the CPU (a uniform or storage buffer, a specialization constant, a literal).
//!
//! This module owns that fit, step for step as the shader evaluates it ([`fit_in_shader`]),
//! the carrier it turns into ([`derived_carrier`]), and the argument for why its result can be
//! trusted. `layer/src/shader/derived_range/fit.rs` emits the same operations in the same order, each
//! decorated `NoContraction`, so what the tests prove here is what the GPU computes (IEEE
//! float32 `+ - * /` are correctly rounded in Vulkan's `Shader` precision for these
//! operations, except division, which Vulkan allows 2.5 ULP: see *Error bound*).
//!
//! # The fit
//!
//! The matrix `M` (the outermost factor of the product the shader multiplies into
//! `Position`, as the shader holds it) has rows `a = r2` (depth) and `b = r3` (w). For a
//! standard perspective `P * X` (X affine) `a = k b + B e3`, so
//!
//! ```text
//! k^ = <a.xyz, b.xyz> / <b.xyz, b.xyz>        B^ = a.w - k^ b.w
//! ```
//!
//! and the guard accepts the fit only where it is a standard perspective line:
//!
//! - `<b.xyz, b.xyz> > 0` and `|b.xyz|^2 >= AFFINE^2 b.w^2` (`AFFINE` =
//!   [`crate::AFFINE_W_TOLERANCE`]): an orthographic or affine matrix has no w to speak of;
//! - the residual `|a.xyz - k^ b.xyz|^2 <= RES^2 |a.xyz|^2` (`RES` =
//!   [`crate::RESIDUAL_TOLERANCE`]): the depth row is on the w row, so it is a projection;
//! - `k^ > 0` and `B^ < 0`, both finite: standard direction, `n = -B^ / k^ > 0`. A matrix
//!   the application already reversed, or a line whose B was lost to rounding (B^ = 0 or the
//!   wrong sign), fails here.
//!
//! A refused fit gives the shader's own z through the flip mapping (`z' = w - z`, the
//! complementary reversal of standard depth: correct, without the precision gain), the same
//! as the flip path would store; for a [-1, 1] clip depth turned into [0, 1] for the draw,
//! `z' = (w - z) / 2` ([`FLIP_IN_SHADER_GL`]).
//!
//! The stored `z' = c_w w + c_1` assumes the vector the matrix multiplies has w = 1 (the
//! line's constant term is `B * v.w`); the rewrite refuses a vector whose w it cannot see is
//! 1 (`vec4(dir, 0.0)` for a sky at infinity would otherwise get the depth of a point at
//! distance w).
//!
//! # The carrier it makes
//!
//! - complementary: `z' = (1 - k^) w - B^`, i.e. `D'(w) = 1 - D(w)` of the fitted line;
//! - infinite: `z' = -B^ / k^ = n`, i.e. `D'(w) = n / w`;
//! - a line fitted in [-1, 1] clip depth is first turned into its [0, 1] line
//!   ([`zero_to_one`]), and the draw gets [0, 1] clip depth.
//!
//! # Error bound (u = 2^-24)
//!
//! Let the exact line be (k, B) and the float32 entries carry the errors of
//! [`crate::camera`]'s module docs. The f64 fit of those entries (`DepthLine::of`) is within
//! `k_error` and `b_error` of (k, B). The float32 evaluation adds, first order:
//!
//! - `<b, b>` and `<a, b>`: 3-term sums of products, each within `gamma_3 = 3u` of its value
//!   (relative to the sum of absolute products; all products of `<b, b>` are positive, and
//!   for a projection the products of `<a, b>` have one sign, `a.xyz ~ k b.xyz`); the
//!   quotient (correctly rounded, or 2.5 ULP) adds 2.5u: `|k^32 - k^64| <= 8.5u |k^|`.
//! - `B^`: `k^ b.w` rounds once (u), the difference once (u of the result), and the error of
//!   k^ enters times `|b.w|`: `|B^32 - B^64| <= u (|B^| + |k^ b.w|) + 8.5u |k^ b.w|`.
//!
//! So the float32 fit is within `b_error + 10u (|a.w| + |k^ b.w|)` of B, about twice
//! [`crate::DepthLine`]'s bound (`8u (|r2.w| + |k^ r3.w|)` plus the residual term): the shader
//! loses about one bit against the CPU's f64 evaluation of the same entries. What matters for
//! depth is not B's error but that every vertex of one matrix gets one line: the fit is a
//! function of the matrix bits alone, evaluated by the same instructions (no contraction), so
//! all vertices, and all draws, of one matrix store depths of one line, `n / w` for infinite,
//! ordered exactly as w is. An error in B moves the near clip plane by its relative size and
//! scales all depths of that matrix alike.
//!
//! Where two draws use *different* matrices of one camera (a precomposed `P * V * M` per
//! object), each has its own fitted B^, and depths of the two are ordered correctly only where
//! their w differ by more than the difference of their B^ (relative). The CPU path's camera
//! table ([`crate::Cameras`]) gives such matrices one range; in the shader there is no table,
//! so per-object precomposed matrices in buffers get per-object ranges. `tests/shader_fit.rs`
//! measures their spread in units of `u d / n` (the flip path's rounding of `1 - D` at the
//! object's distance d, relative to `n / d`): at most 7.3 units over 3000 random pairs (the
//! test allows 16). So between two such objects the depth order is about as fragile as on the
//! flip path (a few times its rounding), while within each object depth is one smooth line.
//! For a shared P (one block with `projection`, `view` and `model`: the outermost factor is P)
//! the near plane is within 2.5u of the camera's; for a shared `P * V` within its f64 bound
//! (measured at most 0.23 of it): every draw of such a frame stores depths of one line.
//!
//! Hot-path note: the function runs per vertex on the GPU; here it is a reference and a test
//! oracle, never called on the layer's hot path.

use crate::classify::{AFFINE_W_TOLERANCE, RESIDUAL_TOLERANCE};
use crate::rewrite::Target;

/// What the fit gives: the depth line `z = k w + B` of the matrix, in float32.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShaderLine {
    /// `k^`.
    pub k: f32,
    /// `B^`.
    pub b: f32,
}

/// `RESIDUAL_TOLERANCE^2` and `AFFINE_W_TOLERANCE^2` as the shader's float32 constants (both
/// powers of two, so exact).
pub const RESIDUAL_TOLERANCE_SQUARED: f32 = (RESIDUAL_TOLERANCE * RESIDUAL_TOLERANCE) as f32;
/// See [`RESIDUAL_TOLERANCE_SQUARED`].
pub const AFFINE_W_TOLERANCE_SQUARED: f32 = (AFFINE_W_TOLERANCE * AFFINE_W_TOLERANCE) as f32;

/// The carrier of a refused fit: `z' = -1 * z + 1 * w + 0`, the flip mapping.
pub const FLIP_IN_SHADER: [f32; 3] = [-1.0, 1.0, 0.0];
/// The same for a [-1, 1] clip depth turned into [0, 1] for the draw: `z' = (w - z) / 2`, the
/// flip mapping of `(D + 1) / 2`.
pub const FLIP_IN_SHADER_GL: [f32; 3] = [-0.5, 0.5, 0.0];

/// The fit of the depth row `a` on the w row `b`, exactly as the rewritten vertex stage
/// evaluates it (float32, left to right, no fused operations), or `None` where the guard
/// refuses it (module docs).
#[must_use]
pub fn fit_in_shader(a: [f32; 4], b: [f32; 4]) -> Option<ShaderLine> {
    let bb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
    let aa = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    let ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let k = ab / bb;
    let (e0, e1, e2) = (a[0] - k * b[0], a[1] - k * b[1], a[2] - k * b[2]);
    let ee = e0 * e0 + e1 * e1 + e2 * e2;
    let b_fit = a[3] - k * b[3];
    let bw2 = b[3] * b[3];
    // Written as the shader's comparisons: each false for NaN, so a NaN anywhere refuses.
    let accepted = bb > 0.0
        && bb >= AFFINE_W_TOLERANCE_SQUARED * bw2
        && ee <= RESIDUAL_TOLERANCE_SQUARED * aa
        && k > 0.0
        && k < f32::INFINITY
        && b_fit < 0.0
        && b_fit > f32::NEG_INFINITY;
    accepted.then_some(ShaderLine { k, b: b_fit })
}

/// The carrier `(c_z, c_w, c_1)` the shader stores `z' = c_z z + c_w w + c_1` with, for the
/// fit (or its refusal) and the mode's target (module docs).
#[must_use]
pub fn derived_carrier(line: Option<ShaderLine>, target: Target) -> [f32; 3] {
    match (line, target) {
        (Some(ShaderLine { k, b }), Target::Complementary) => [0.0, 1.0 - k, -b],
        (Some(ShaderLine { k, b }), Target::Infinite) => [0.0, 0.0, -b / k],
        (None, _) => FLIP_IN_SHADER,
    }
}

/// The [0, 1] line of a line fitted in [-1, 1] clip depth (`VK_EXT_depth_clip_control`'s
/// `negativeOneToOne`, Zink's): `D01 = (D + 1) / 2`, so `k01 = (k + 1) / 2`, `B01 = B / 2`
/// (evaluated in this order; the halving is exact). revz sets [0, 1] for such draws, where
/// reversed depth near 0 keeps float32's resolution: `2 n / w - 1` in [-1, 1] would not.
#[must_use]
pub fn zero_to_one(line: ShaderLine) -> ShaderLine {
    ShaderLine {
        k: (line.k + 1.0) * 0.5,
        b: line.b * 0.5,
    }
}

/// The rows `(r2, r3)` of a matrix as the shader holds it: `columns[c][r]` is row r, column
/// c of `clip = M * v` (`OpMatrixTimesVector`); `transposed` for `v * X`
/// (`OpVectorTimesMatrix`), where `M = X^T`, so the rows are X's columns.
#[must_use]
pub fn depth_and_w_rows(columns: &[[f32; 4]; 4], transposed: bool) -> ([f32; 4], [f32; 4]) {
    if transposed {
        (columns[2], columns[3])
    } else {
        let row = |r: usize| [columns[0][r], columns[1][r], columns[2][r], columns[3][r]];
        (row(2), row(3))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{dcamera::rh::proj::vulkan, DMat4};

    fn rows(m: DMat4) -> ([f32; 4], [f32; 4]) {
        let c = m.as_mat4().to_cols_array_2d();
        depth_and_w_rows(&c, false)
    }

    #[test]
    fn a_projection_fits_its_own_line_and_orthographic_or_reversed_ones_are_refused() {
        let p = vulkan::perspective(1.0, 1.5, 0.1, 100.0);
        let (a, b) = rows(p);
        let line = fit_in_shader(a, b).expect("a standard perspective");
        assert!((f64::from(-line.b / line.k) / 0.1 - 1.0).abs() < 1e-6);
        let ortho = glam::dcamera::rh::proj::vulkan::orthographic(-1.0, 1.0, -1.0, 1.0, 0.1, 100.0);
        let (a, b) = rows(ortho);
        assert_eq!(fit_in_shader(a, b), None);
        // Reversed (the application's own reversed-Z): D' = 1 - D, r2' = r3 - r2.
        let (a, b) = rows(p);
        let reversed: [f32; 4] = std::array::from_fn(|i| b[i] - a[i]);
        assert_eq!(fit_in_shader(reversed, b), None);
        let (mut a, b) = rows(p);
        a[0] = 0.5; // not on the w row
        assert_eq!(fit_in_shader(a, b), None);
        assert_eq!(fit_in_shader([f32::NAN; 4], b), None);
        assert_eq!(derived_carrier(None, Target::Infinite), FLIP_IN_SHADER);
    }

    #[test]
    fn transposed_rows_are_columns() {
        let c = [
            [1.0, 2.0, 3.0, 4.0],
            [5.0, 6.0, 7.0, 8.0],
            [9.0; 4],
            [0.0; 4],
        ];
        assert_eq!(depth_and_w_rows(&c, true), (c[2], c[3]));
        assert_eq!(depth_and_w_rows(&c, false).0, [3.0, 7.0, 9.0, 0.0]);
    }
}
