//! Classification of a clip-space transform by what its depth row does: standard perspective
//! (to be rewritten), orthographic/affine, already reversed, or not a projection.
//!
//! `DESIGN.md` section 1: for every perspective projection, with or without view and model
//! matrices folded in, either handedness, y flipped or not, the depth row is an affine
//! combination of the w row, `r2 = k * r3 + B * e3`. Handedness, y flip, storage order and the
//! folded model-view do not matter: r3 is whatever the w row is. The steps:
//!
//! 1. Any NaN or infinite entry: [`Rejection::NonFinite`]. A w row of zeros:
//!    [`Rejection::ZeroWRow`].
//! 2. `|r3.xyz| <= AFFINE_W_TOLERANCE * |r3.w|`: w is (almost) constant, depth is linear in
//!    the position: [`Classification::Orthographic`]. Orthographic projections and model
//!    matrices land here alike; they cannot be told apart by value (`DESIGN.md` section 2).
//! 3. Least-squares fit on the xyz parts, `k = <r2.xyz, r3.xyz> / <r3.xyz, r3.xyz>`, relative
//!    residual `|r2.xyz - k * r3.xyz| / |r2.xyz|` (0 when `r2.xyz = 0`, the infinite-reversed
//!    row). Above [`RESIDUAL_TOLERANCE`]: [`Rejection::DepthRowNotOnWRow`].
//! 4. `B = r2.w - k * r3.w`; the visible range from (k, B) under the pipeline's convention
//!    ([`crate::DepthCoefficients::visible_range`]); a degenerate one is
//!    [`Rejection::Range`]. B < 0 is [`Classification::Perspective`], B > 0
//!    [`Classification::Reversed`] (finite or infinite by the recovered far plane).
//!
//! The range is what the application's float32 matrix renders, not what it meant
//! (`DESIGN.md` section 1). For a precomposed P*V*M whose w row has a large constant term
//! `r3.w` (a camera far from the model's origin), float32 rounding of `r2.w` can be large
//! against B: the recovered near plane then differs from the application's intended one, or
//! the line is rejected as degenerate. It is still the projection the float32 matrix applies,
//! up to the residual. The rounding uncertainty of B is about
//! `u * (|r2.w| + 3 |k| |r3.w|)` (u = 2^-24, derivation in `tests/properties.rs`); where that
//! exceeds |B| even the sign of B is noise, and such a matrix may come out as
//! [`Classification::Reversed`] or [`Rejection::Range`]: left untouched either way, but a
//! layer that infers "the application already uses reversed depth" from one matrix should
//! weigh that.

use glam::DMat4;

use crate::range::{DepthCoefficients, DepthConvention, DepthDirection, RangeError, VisibleRange};

/// Largest accepted relative residual of the depth-row fit: 2^-16 (about 1.5e-5).
///
/// Where it comes from: a P*V*M whose entries are each rounded once to float32 (relative error
/// at most u = 2^-24 per entry) has a residual of at most 2u (the rounding of r2 and of k * r3,
/// `DESIGN.md` section 1); a product accumulated in float32 adds at most a few `gamma_4`
/// (4u) terms per entry for rotation and uniform-scale model-views. The largest residual seen
/// in the property tests (matrices rounded once, cameras up to 10 km from the origin) is below
/// 1e-7. The residual does not grow with the camera's distance, which only enters `r2.w` and
/// `r3.w`. 2^-16 = 256u leaves a factor of over 100 for float32 accumulation chains. On the
/// other side a random matrix has a residual of sin(angle(r2.xyz, r3.xyz)), of order 1; the
/// chance that a random direction lies within 2^-16 of another is about 1e-10 (the smallest
/// residual seen over 10^4 random matrices is above 1e-3).
///
/// The residual is relative to `|r2.xyz|`, so it is not invariant to scaling the xyz columns:
/// when one column is 1e5 times larger than the others in both rows, the small columns hardly
/// count, and a matrix that is not a projection there can pass. Rewriting it drops at most
/// `residual * |r2.xyz| * |v.xyz| / w` of depth.
pub const RESIDUAL_TOLERANCE: f64 = 1.0 / 65536.0;

/// Largest `|r3.xyz| / |r3.w|` for which w counts as constant (affine, orthographic): 2^-20
/// (about 9.5e-7).
///
/// Where it comes from: an orthographic projection composed with affine view and model
/// matrices has a w row of exactly e3 (`0 * x` sums are exact), so this only has to absorb
/// noise from a general 4x4 inverse (about 1e-7 relative in float32). A perspective P*V*M has
/// `|r3.xyz| / |r3.w|` = model scale / distance of the model origin along the view axis; below
/// 2^-20 (a unit-scale model whose origin is a million units ahead) its w cannot vary across
/// float32-representable positions by more than the rounding of `r3.w` itself. Such a matrix is
/// treated as affine: its exact finite reversal is still correct, only without the precision
/// gain.
pub const AFFINE_W_TOLERANCE: f64 = 1.0 / 1_048_576.0;

/// What a clip-space transform does with depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Classification {
    /// A standard perspective projection (B < 0): depth grows with distance. Rewrite it.
    Perspective {
        /// The multiple of the w row in the depth row.
        k: f64,
        /// The constant term of the depth row.
        b: f64,
        /// Relative residual of the fit (at most [`RESIDUAL_TOLERANCE`]).
        residual: f64,
        /// The visible range it renders.
        range: VisibleRange,
        /// The convention the range was recovered under.
        convention: DepthConvention,
    },
    /// w is constant: depth is linear (orthographic projection, shadow projection, or a model
    /// matrix). Its reversal is the exact finite one, never the infinite form.
    Orthographic {
        /// The convention the reversal is made in.
        convention: DepthConvention,
    },
    /// Already reversed (B > 0); `range.is_infinite()` tells infinite reversed from
    /// complementary. Left untouched.
    Reversed {
        /// The multiple of the w row in the depth row.
        k: f64,
        /// The constant term of the depth row.
        b: f64,
        /// Relative residual of the fit (at most [`RESIDUAL_TOLERANCE`]).
        residual: f64,
        /// The visible range it renders.
        range: VisibleRange,
        /// The convention the range was recovered under.
        convention: DepthConvention,
    },
    /// Not a projection the layer may rewrite. Left untouched.
    NotProjection(Rejection),
}

impl Classification {
    /// The recovered visible range, for perspective and reversed projections.
    #[must_use]
    pub fn range(&self) -> Option<VisibleRange> {
        match self {
            Self::Perspective { range, .. } | Self::Reversed { range, .. } => Some(*range),
            Self::Orthographic { .. } | Self::NotProjection(_) => None,
        }
    }
}

/// Why a matrix is not a projection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Rejection {
    /// An entry is NaN or infinite (or the fit overflowed).
    NonFinite,
    /// The w row is zero.
    ZeroWRow,
    /// w varies, but the depth row is not `k * r3 + B * e3` within [`RESIDUAL_TOLERANCE`].
    DepthRowNotOnWRow {
        /// The relative residual of the fit.
        residual: f64,
    },
    /// The depth row is on the w row, but (k, B) gives no usable visible range.
    Range(RangeError),
}

/// The least-squares depth line of a matrix whose w row varies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthFit {
    /// (k, B) of `r2 ~ k * r3 + B * e3`.
    pub coefficients: DepthCoefficients,
    /// `|r2.xyz - k * r3.xyz| / |r2.xyz|`, 0 when `r2.xyz = 0`.
    pub residual: f64,
}

/// Fits `r2 = k * r3 + B * e3` (step 3 and the first half of step 4 of the module docs).
/// Does not apply the residual tolerance.
///
/// # Errors
///
/// [`Rejection::NonFinite`] when the w row's xyz part is zero or the fit is not finite.
pub fn fit_depth_row(m: &DMat4) -> Result<DepthFit, Rejection> {
    let depth_row = m.row(2);
    let w_row = m.row(3);
    let (depth_xyz, w_xyz) = (depth_row.truncate(), w_row.truncate());
    let k = depth_xyz.dot(w_xyz) / w_xyz.length_squared();
    let depth_xyz_length = depth_xyz.length();
    let residual = if depth_xyz_length == 0.0 {
        0.0
    } else {
        (depth_xyz - k * w_xyz).length() / depth_xyz_length
    };
    let b = depth_row.w - k * w_row.w;
    if !(k.is_finite() && b.is_finite() && residual.is_finite()) {
        return Err(Rejection::NonFinite);
    }
    Ok(DepthFit {
        coefficients: DepthCoefficients { k, b },
        residual,
    })
}

/// Classifies the clip-space transform `m` (`clip = m * v`) under the pipeline's depth
/// `convention`. Never panics.
#[must_use]
pub fn classify(m: &DMat4, convention: DepthConvention) -> Classification {
    if !m.is_finite() {
        return Classification::NotProjection(Rejection::NonFinite);
    }
    let w_row = m.row(3);
    let w_xyz_length = w_row.truncate().length();
    if w_xyz_length == 0.0 && w_row.w == 0.0 {
        return Classification::NotProjection(Rejection::ZeroWRow);
    }
    if w_xyz_length <= AFFINE_W_TOLERANCE * w_row.w.abs() {
        return Classification::Orthographic { convention };
    }
    let fit = match fit_depth_row(m) {
        Ok(fit) => fit,
        Err(rejection) => return Classification::NotProjection(rejection),
    };
    if fit.residual > RESIDUAL_TOLERANCE {
        return Classification::NotProjection(Rejection::DepthRowNotOnWRow {
            residual: fit.residual,
        });
    }
    let DepthCoefficients { k, b } = fit.coefficients;
    match fit.coefficients.visible_range(convention) {
        Ok((DepthDirection::Standard, range)) => Classification::Perspective {
            k,
            b,
            residual: fit.residual,
            range,
            convention,
        },
        Ok((DepthDirection::Reversed, range)) => Classification::Reversed {
            k,
            b,
            residual: fit.residual,
            range,
            convention,
        },
        Err(error) => Classification::NotProjection(Rejection::Range(error)),
    }
}

#[cfg(test)]
mod tests {
    use glam::dcamera::{lh, rh};
    use glam::{DMat4, DQuat, DVec3, DVec4};

    use super::*;
    use crate::matrix::{from_rows, E3};

    const ZERO_TO_ONE: DepthConvention = DepthConvention::ZeroToOne;
    const FOV: f64 = 1.0;
    const ASPECT: f64 = 1.5;

    fn perspective_range(classification: Classification) -> VisibleRange {
        match classification {
            Classification::Perspective { range, .. } => range,
            other => panic!("expected a perspective projection, got {other:?}"),
        }
    }

    fn reversed_range(classification: Classification) -> VisibleRange {
        match classification {
            Classification::Reversed { range, .. } => range,
            other => panic!("expected a reversed projection, got {other:?}"),
        }
    }

    #[test]
    fn exact_table_matrices_classify_exactly() {
        // n = 1, f = 5: every coefficient is a binary fraction.
        let (n, f) = (1.0, 5.0);
        for m in [
            rh::proj::vulkan::perspective(FOV, ASPECT, n, f),
            rh::proj::directx::perspective(FOV, ASPECT, n, f),
            lh::proj::directx::perspective(FOV, ASPECT, n, f),
        ] {
            let classification = classify(&m, ZERO_TO_ONE);
            let Classification::Perspective { k, b, residual, .. } = classification else {
                panic!("{classification:?}");
            };
            assert_eq!((k, b, residual), (1.25, -1.25, 0.0));
            let range = perspective_range(classification);
            assert_eq!((range.near(), range.far()), (n, f));
        }
    }

    #[test]
    fn standard_infinite_is_perspective_with_infinite_far() {
        let m = rh::proj::vulkan::perspective_infinite(FOV, ASPECT, 0.25);
        let range = perspective_range(classify(&m, ZERO_TO_ONE));
        assert_eq!(range.near(), 0.25);
        assert!(range.is_infinite());
    }

    #[test]
    fn reversed_matrices_are_detected() {
        let infinite = rh::proj::vulkan::perspective_infinite_reverse(FOV, ASPECT, 0.25);
        let range = reversed_range(classify(&infinite, ZERO_TO_ONE));
        assert_eq!(range.near(), 0.25);
        assert!(range.is_infinite());
        // glam has no complementary constructor; swapping near and far of the standard one
        // gives it (k = -n/(f-n), B = fn/(f-n)).
        let complementary = rh::proj::vulkan::perspective(FOV, ASPECT, 5.0, 1.0);
        let range = reversed_range(classify(&complementary, ZERO_TO_ONE));
        assert_eq!((range.near(), range.far()), (1.0, 5.0));
    }

    #[test]
    fn opengl_convention_recovers_the_same_range() {
        let m = rh::proj::opengl::perspective(FOV, ASPECT, 1.0, 5.0);
        let range = perspective_range(classify(&m, DepthConvention::NegativeOneToOne));
        assert_eq!((range.near(), range.far()), (1.0, 5.0));
    }

    #[test]
    fn folded_view_and_model_do_not_matter() {
        let projection = rh::proj::vulkan::perspective(FOV, ASPECT, 0.5, 300.0);
        let view = rh::view::look_at_mat4(
            DVec3::new(3.0, 7.0, -2.0),
            DVec3::new(0.0, 1.0, 0.5),
            DVec3::Y,
        );
        let model = DMat4::from_scale_rotation_translation(
            DVec3::splat(2.5),
            DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7),
            DVec3::new(-4.0, 1.0, 9.0),
        );
        let range = perspective_range(classify(&(projection * view * model), ZERO_TO_ONE));
        assert!((range.near() / 0.5 - 1.0).abs() < 1e-12);
        assert!((range.far() / 300.0 - 1.0).abs() < 1e-10);
    }

    #[test]
    fn affine_matrices_are_orthographic() {
        let ortho = rh::proj::vulkan::orthographic(-2.0, 2.0, -1.0, 1.0, 0.5, 50.0);
        let model = DMat4::from_scale_rotation_translation(
            DVec3::splat(3.0),
            DQuat::from_rotation_y(0.3),
            DVec3::new(1.0, 2.0, 3.0),
        );
        for m in [ortho, model, DMat4::IDENTITY, ortho * model] {
            assert_eq!(
                classify(&m, ZERO_TO_ONE),
                Classification::Orthographic {
                    convention: ZERO_TO_ONE
                }
            );
        }
    }

    #[test]
    fn rejections() {
        let perspective = rh::proj::vulkan::perspective(FOV, ASPECT, 1.0, 5.0);
        let mut with_nan = perspective;
        with_nan.x_axis.x = f64::NAN;
        assert_eq!(
            classify(&with_nan, ZERO_TO_ONE),
            Classification::NotProjection(Rejection::NonFinite)
        );
        let zero_w = from_rows([DVec4::X, DVec4::Y, DVec4::Z, DVec4::ZERO]);
        assert_eq!(
            classify(&zero_w, ZERO_TO_ONE),
            Classification::NotProjection(Rejection::ZeroWRow)
        );
        assert_eq!(
            classify(&DMat4::ZERO, ZERO_TO_ONE),
            Classification::NotProjection(Rejection::ZeroWRow)
        );
        // Depth row tilted away from the w row.
        let tilted = from_rows([
            DVec4::X,
            DVec4::Y,
            DVec4::new(0.01, 0.0, -1.25, -1.25),
            DVec4::new(0.0, 0.0, -1.0, 0.0),
        ]);
        assert!(matches!(
            classify(&tilted, ZERO_TO_ONE),
            Classification::NotProjection(Rejection::DepthRowNotOnWRow { .. })
        ));
        // Constant depth.
        let constant = from_rows([DVec4::X, DVec4::Y, 0.5 * -DVec4::Z, -DVec4::Z]);
        assert_eq!(
            classify(&constant, ZERO_TO_ONE),
            Classification::NotProjection(Rejection::Range(RangeError::ConstantDepth))
        );
        // Everything behind the camera: a standard line with k < 0.
        let behind = from_rows([
            DVec4::X,
            DVec4::Y,
            DVec4::new(0.0, 0.0, 1.0, -1.0),
            -DVec4::Z,
        ]);
        assert_eq!(
            classify(&behind, ZERO_TO_ONE),
            Classification::NotProjection(Rejection::Range(RangeError::NearNotPositive))
        );
        // Sanity: E3 as a w row is affine.
        let affine = from_rows([DVec4::X, DVec4::Y, DVec4::Z, E3]);
        assert!(matches!(
            classify(&affine, ZERO_TO_ONE),
            Classification::Orthographic { .. }
        ));
    }
}
