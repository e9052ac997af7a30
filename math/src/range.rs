//! The depth line (k, B) of a perspective projection and the visible range (n, f) it renders,
//! in both directions, under the pipeline's depth convention.
//!
//! `DESIGN.md` section 1: seen from the depth buffer, a perspective projection is two numbers,
//! `z_clip = k * w_clip + B`, so the normalized depth is `D(w) = k + B / w`. Whether depth grows
//! with distance is the sign of B (B < 0 standard, B > 0 reversed). The convention fixes the
//! normalized depth interval [lo, hi]: [0, 1] in Vulkan, [-1, 1] when a pipeline enables
//! `VkPipelineViewportDepthClipControlCreateInfoEXT::negativeOneToOne` (OpenGL style).
//!
//! With `d_n` the depth at the near plane and `d_f` the depth at the far plane
//! (standard: `d_n = lo, d_f = hi`; reversed: `d_n = hi, d_f = lo`), solving `D(w) = d` gives
//!
//! ```text
//! n = B / (d_n - k)                                  must be finite and > 0
//! f = B / (d_f - k)   if that is > 0, otherwise f = infinity
//! ```
//!
//! and `f > n` follows whenever both are positive (`|d_f - k| < |d_n - k|`). "Otherwise
//! infinity" covers k exactly at the infinite limit (k = d_f: `D` reaches `d_f` only at
//! infinity, the standard-infinite k = 1 and infinite-reversed k = 0 of the `DESIGN.md` table)
//! and k beyond it (`D` never reaches `d_f`: nothing is far-clipped). The latter is what a
//! float32 matrix whose f/n is beyond 1/eps looks like, since its k rounds to the limit or just
//! past it.
//!
//! The inverse, (k, B) from (n, f), is [`DepthCoefficients::standard`] and
//! [`DepthCoefficients::reversed`]; for [0, 1] they are the rows of the `DESIGN.md` table
//! (f/(f-n), -fn/(f-n)), (1, -n), (-n/(f-n), fn/(f-n)), (0, n); for [-1, 1] the OpenGL row
//! ((f+n)/(f-n), -2fn/(f-n)) and its negation.
//!
//! n and f are values of `w_clip`. They are view-space distances when the w row has unit
//! length in view space (every projection of seed 002 and glam); a scaled w row scales them,
//! and the rewrite stays consistent because it keeps the same w row.

/// The normalized-device depth interval the pipeline clips to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DepthConvention {
    /// Vulkan's default: clip depth in [0, 1].
    ZeroToOne,
    /// `negativeOneToOne` (OpenGL style): clip depth in [-1, 1].
    NegativeOneToOne,
}

impl DepthConvention {
    /// The normalized depth interval `(lo, hi)` of the convention.
    #[must_use]
    pub fn interval(self) -> (f64, f64) {
        match self {
            Self::ZeroToOne => (0.0, 1.0),
            Self::NegativeOneToOne => (-1.0, 1.0),
        }
    }
}

/// Whether depth grows with distance (standard) or shrinks (reversed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DepthDirection {
    /// Near plane at `lo`, far plane at `hi` (B < 0).
    Standard,
    /// Near plane at `hi`, far plane at `lo` (B > 0).
    Reversed,
}

/// Why (k, B) does not describe a usable visible range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RangeError {
    /// k or B is NaN or infinite, or n came out non-finite.
    NonFinite,
    /// B = 0: the depth is the constant k, independent of distance.
    ConstantDepth,
    /// The near plane would sit at w <= 0 (nothing in front of the camera is visible).
    NearNotPositive,
    /// The far plane would not lie beyond the near plane.
    FarNotBeyondNear,
}

impl std::fmt::Display for RangeError {
    fn fmt(&self, formatter: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        formatter.write_str(match self {
            Self::NonFinite => "depth coefficients are not finite",
            Self::ConstantDepth => "depth does not depend on distance (B = 0)",
            Self::NearNotPositive => "near plane at w <= 0",
            Self::FarNotBeyondNear => "far plane not beyond the near plane",
        })
    }
}

impl std::error::Error for RangeError {}

/// The visible range of a perspective projection, in units of `w_clip`: `0 < near < far`,
/// `far` possibly `f64::INFINITY`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisibleRange {
    near: f64,
    far: f64,
}

impl VisibleRange {
    /// A range with `0 < near < far`, `near` finite, `far` finite or `f64::INFINITY`.
    ///
    /// # Errors
    ///
    /// [`RangeError::NonFinite`] for a NaN or infinite `near` (or a NaN `far`),
    /// [`RangeError::NearNotPositive`] for `near <= 0`, [`RangeError::FarNotBeyondNear`] for
    /// `far <= near`.
    pub fn new(near: f64, far: f64) -> Result<Self, RangeError> {
        if !near.is_finite() || far.is_nan() {
            return Err(RangeError::NonFinite);
        }
        if near <= 0.0 {
            return Err(RangeError::NearNotPositive);
        }
        if far <= near {
            return Err(RangeError::FarNotBeyondNear);
        }
        Ok(Self { near, far })
    }

    /// An infinite range starting at `near` (`far = f64::INFINITY`).
    ///
    /// # Errors
    ///
    /// As [`VisibleRange::new`].
    pub fn infinite(near: f64) -> Result<Self, RangeError> {
        Self::new(near, f64::INFINITY)
    }

    /// The near plane, `w = n`.
    #[must_use]
    pub fn near(&self) -> f64 {
        self.near
    }

    /// The far plane, `w = f`; `f64::INFINITY` for an infinite projection.
    #[must_use]
    pub fn far(&self) -> f64 {
        self.far
    }

    /// Whether the far plane is at infinity.
    #[must_use]
    pub fn is_infinite(&self) -> bool {
        self.far == f64::INFINITY
    }
}

/// The depth line of a perspective projection: `z_clip = k * w_clip + b`, `D(w) = k + b / w`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthCoefficients {
    /// The multiple of the w row in the depth row.
    pub k: f64,
    /// The constant term of the depth row (`B` in `DESIGN.md`).
    pub b: f64,
}

impl DepthCoefficients {
    /// Normalized depth `D(w) = k + b / w` at `w_clip = w`.
    #[must_use]
    pub fn depth_at(&self, w: f64) -> f64 {
        self.k + self.b / w
    }

    /// The standard mapping of `range`: `D(n) = lo`, `D(f) = hi`.
    ///
    /// `b = (lo - hi) * n * f / (f - n)`, `k = hi - b / f`; for an infinite range
    /// `k = hi`, `b = (lo - hi) * n`.
    #[must_use]
    pub fn standard(range: VisibleRange, convention: DepthConvention) -> Self {
        let (lo, hi) = convention.interval();
        Self::through(range, lo, hi)
    }

    /// The reversed mapping of `range`: `D(n) = hi`, `D(f) = lo`, i.e. `D' = lo + hi - D` of
    /// the standard one.
    ///
    /// For [0, 1]: complementary `(-n/(f-n), f*n/(f-n))`, infinite `(0, n)`. For [-1, 1]:
    /// `(-(f+n)/(f-n), 2fn/(f-n))`, infinite `(-1, 2n)`.
    #[must_use]
    pub fn reversed(range: VisibleRange, convention: DepthConvention) -> Self {
        let (lo, hi) = convention.interval();
        Self::through(range, hi, lo)
    }

    /// The line through `D(n) = depth_near` and `D(f) = depth_far`.
    fn through(range: VisibleRange, depth_near: f64, depth_far: f64) -> Self {
        let span = depth_far - depth_near;
        if range.is_infinite() {
            // D(w) = depth_far - span * n / w.
            return Self {
                k: depth_far,
                b: -span * range.near,
            };
        }
        let (near, far) = (range.near, range.far);
        // n / (f - n) and f / (f - n) rather than n * f / (f - n), so that nothing overflows
        // for a huge f.
        let near_over_depth = near / (far - near);
        Self {
            k: depth_far + span * near_over_depth,
            b: -span * near * (far / (far - near)),
        }
    }

    /// Recovers the direction and the visible range from (k, b) under `convention` (formulas
    /// in the module documentation). Never panics.
    ///
    /// # Errors
    ///
    /// A [`RangeError`] when (k, b) are not finite, b = 0, or the planes do not satisfy
    /// `0 < n < f`.
    pub fn visible_range(
        &self,
        convention: DepthConvention,
    ) -> Result<(DepthDirection, VisibleRange), RangeError> {
        let Self { k, b } = *self;
        if !k.is_finite() || !b.is_finite() {
            return Err(RangeError::NonFinite);
        }
        let (lo, hi) = convention.interval();
        let (direction, depth_near, depth_far) = if b < 0.0 {
            (DepthDirection::Standard, lo, hi)
        } else if b > 0.0 {
            (DepthDirection::Reversed, hi, lo)
        } else {
            return Err(RangeError::ConstantDepth);
        };
        let near = b / (depth_near - k);
        if near.is_nan() {
            return Err(RangeError::NonFinite);
        }
        if near <= 0.0 {
            return Err(RangeError::NearNotPositive);
        }
        let far_candidate = b / (depth_far - k);
        // Zero denominator (k at the infinite limit) gives +-inf or a negative value when k is
        // past the limit: the far plane is at infinity.
        let far = if far_candidate > 0.0 {
            far_candidate
        } else {
            f64::INFINITY
        };
        VisibleRange::new(near, far).map(|range| (direction, range))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // n = 1, f = 5 makes every entry of the DESIGN.md table a binary fraction: exact tests.
    fn one_to_five() -> VisibleRange {
        VisibleRange::new(1.0, 5.0).expect("valid range")
    }

    #[test]
    fn design_table_zero_to_one() {
        let range = one_to_five();
        let standard = DepthCoefficients::standard(range, DepthConvention::ZeroToOne);
        assert_eq!(standard, DepthCoefficients { k: 1.25, b: -1.25 });
        let complementary = DepthCoefficients::reversed(range, DepthConvention::ZeroToOne);
        assert_eq!(complementary, DepthCoefficients { k: -0.25, b: 1.25 });
        let infinite = VisibleRange::infinite(1.0).expect("valid range");
        assert_eq!(
            DepthCoefficients::standard(infinite, DepthConvention::ZeroToOne),
            DepthCoefficients { k: 1.0, b: -1.0 }
        );
        assert_eq!(
            DepthCoefficients::reversed(infinite, DepthConvention::ZeroToOne),
            DepthCoefficients { k: 0.0, b: 1.0 }
        );
    }

    #[test]
    fn design_table_negative_one_to_one() {
        let range = one_to_five();
        let standard = DepthCoefficients::standard(range, DepthConvention::NegativeOneToOne);
        // (f+n)/(f-n) = 1.5, -2fn/(f-n) = -2.5.
        assert_eq!(standard, DepthCoefficients { k: 1.5, b: -2.5 });
        let reversed = DepthCoefficients::reversed(range, DepthConvention::NegativeOneToOne);
        assert_eq!(reversed, DepthCoefficients { k: -1.5, b: 2.5 });
        let infinite = VisibleRange::infinite(1.0).expect("valid range");
        assert_eq!(
            DepthCoefficients::reversed(infinite, DepthConvention::NegativeOneToOne),
            DepthCoefficients { k: -1.0, b: 2.0 }
        );
    }

    #[test]
    fn depth_at_the_planes() {
        let range = one_to_five();
        for convention in [
            DepthConvention::ZeroToOne,
            DepthConvention::NegativeOneToOne,
        ] {
            let (lo, hi) = convention.interval();
            let standard = DepthCoefficients::standard(range, convention);
            assert_eq!(standard.depth_at(1.0), lo);
            assert_eq!(standard.depth_at(5.0), hi);
            let reversed = DepthCoefficients::reversed(range, convention);
            assert_eq!(reversed.depth_at(1.0), hi);
            assert_eq!(reversed.depth_at(5.0), lo);
        }
    }

    #[test]
    fn recovers_every_table_row() {
        let finite = one_to_five();
        let infinite = VisibleRange::infinite(1.0).expect("valid range");
        for convention in [
            DepthConvention::ZeroToOne,
            DepthConvention::NegativeOneToOne,
        ] {
            for range in [finite, infinite] {
                let standard = DepthCoefficients::standard(range, convention);
                assert_eq!(
                    standard.visible_range(convention),
                    Ok((DepthDirection::Standard, range))
                );
                let reversed = DepthCoefficients::reversed(range, convention);
                assert_eq!(
                    reversed.visible_range(convention),
                    Ok((DepthDirection::Reversed, range))
                );
            }
        }
    }

    #[test]
    fn k_past_the_infinite_limit_is_infinite() {
        let just_below = DepthCoefficients {
            k: 1.0 - f64::EPSILON,
            b: -0.1,
        };
        let (direction, range) = just_below
            .visible_range(DepthConvention::ZeroToOne)
            .expect("valid");
        assert_eq!(direction, DepthDirection::Standard);
        assert!(range.is_infinite());
        let reversed_past = DepthCoefficients { k: 1e-9, b: 0.1 };
        let (direction, range) = reversed_past
            .visible_range(DepthConvention::ZeroToOne)
            .expect("valid");
        assert_eq!(direction, DepthDirection::Reversed);
        assert!(range.is_infinite());
    }

    #[test]
    fn opengl_matrix_read_as_vulkan_gives_another_range() {
        // Pitfall 8: the convention matters. The [-1,1] line for (1, 5) read under [0,1] puts
        // the near plane where D = 0, i.e. at 2fn/(f+n) = 5/3.
        let gl = DepthCoefficients::standard(one_to_five(), DepthConvention::NegativeOneToOne);
        let (_, misread) = gl.visible_range(DepthConvention::ZeroToOne).expect("valid");
        assert!((misread.near() - 5.0 / 3.0).abs() < 1e-15);
        assert_eq!(misread.far(), 5.0);
    }

    #[test]
    fn degenerate_lines_are_errors() {
        let zero_to_one = DepthConvention::ZeroToOne;
        let cases = [
            (f64::NAN, -1.0, RangeError::NonFinite),
            (1.0, f64::INFINITY, RangeError::NonFinite),
            (1.0, 0.0, RangeError::ConstantDepth),
            // Standard with k <= 0: D < 0 everywhere in front of the camera.
            (-0.5, -1.0, RangeError::NearNotPositive),
            (0.0, -1.0, RangeError::NearNotPositive),
            // Reversed with k = 1: the near plane at infinity.
            (1.0, 1.0, RangeError::NonFinite),
            // Reversed with k >= 1: D > 1 everywhere.
            (1.5, 1.0, RangeError::NearNotPositive),
        ];
        for (k, b, expected) in cases {
            let line = DepthCoefficients { k, b };
            assert_eq!(
                line.visible_range(zero_to_one),
                Err(expected),
                "k={k} b={b}"
            );
        }
    }

    #[test]
    fn range_constructor_rejects_bad_planes() {
        assert_eq!(
            VisibleRange::new(0.0, 1.0),
            Err(RangeError::NearNotPositive)
        );
        assert_eq!(
            VisibleRange::new(2.0, 1.0),
            Err(RangeError::FarNotBeyondNear)
        );
        assert_eq!(
            VisibleRange::new(1.0, 1.0),
            Err(RangeError::FarNotBeyondNear)
        );
        assert_eq!(
            VisibleRange::new(f64::INFINITY, f64::INFINITY),
            Err(RangeError::NonFinite)
        );
        assert_eq!(VisibleRange::new(1.0, f64::NAN), Err(RangeError::NonFinite));
    }
}
