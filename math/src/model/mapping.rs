//! The depth mappings `D(w)` the model compares, each with its exact inverse and slope in f64.
//!
//! The model needs the mappings of all three seeds side by side, including those a projection
//! matrix cannot produce (W, logarithmic), so that storage formats and the float32 vertex path
//! can be judged against the best conceivable depth buffer, not only against each other. Every
//! formula is evaluated in a factored form that keeps its relative accuracy where D goes to 0
//! (`f - w` rather than `f / w - 1`), because float storage resolves D relative to its size
//! there and the model must not be less precise than the format it models.

use crate::range::{DepthCoefficients, DepthConvention, VisibleRange};

/// A function from view depth `w` (distance along the view axis, `w_clip`) in `[n, f]` to the
/// normalized depth `D` in `[0, 1]`.
///
/// Names follow seed 000 (Lapidous & Jiao, eq. 3, 4, 5, 8; seed 003 gives the same three
/// non-standard buffers). `n` and `f` are the planes of the [`VisibleRange`]; seed 000 calls
/// them `d` and `f`, and the view depth `Z_e`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mapping {
    /// Screen Z, seed 000 eq. (3): `D = f/(f-n) * (1 - n/w)`, 0 at n, 1 at f (compare LESS).
    /// With an infinite far plane, `D = 1 - n/w`.
    Standard,
    /// Complementary Z, seed 000 eq. (8): `D = 1 - Z = n/(f-n) * (f/w - 1)`, 1 at n, 0 at f
    /// (compare GREATER). With an infinite far plane it is `n / w`.
    Complementary,
    /// Infinite reversed-Z (`DESIGN.md` section 1): `D = n / w`, 1 at n, 0 at infinity
    /// (compare GREATER); the far plane of the range, if finite, only clips.
    InfiniteReversed,
    /// W buffer, seed 000 eq. (4): `D = w / f`, stored linearly (compare LESS). This is seed
    /// 000's (and seed 003's) definition, not seed 002's `(w - n) / (f - n)`: the two differ
    /// by the unused `[0, n/f)` of the range, which is negligible for `f >> n`.
    W,
    /// Inverse W ("1/Z") buffer, seed 000 eq. (5): `D = n / w`, from 1 at n down to `n / f`
    /// at f (compare GREATER).
    ///
    /// As a function of w this is exactly [`Mapping::InfiniteReversed`] (seed 001, section 6:
    /// "inverse W, having a = 0 and b = n"); seed 000 (section 3) explains its weakness
    /// against complementary Z by `[0, n/f)` staying unused, which is what the infinite
    /// reversed projection gives up too when the scene ends at a finite f. The two names are
    /// kept apart because they come from different pipelines: inverse W is the per-pixel
    /// `rhw` of seed 000, infinite reversed the projection matrix `(0, n)` of `DESIGN.md`,
    /// which [`super::Simulation`] runs through the float32 vertex path.
    InverseW,
    /// Logarithmic depth: `D = ln(w / n) / ln(f / n)` (compare LESS). Constant relative
    /// resolution; written from the fragment shader (`DESIGN.md` pitfall 10), never by a
    /// projection matrix.
    Logarithmic,
}

impl Mapping {
    /// Every mapping, in declaration order.
    pub const ALL: [Self; 6] = [
        Self::Standard,
        Self::Complementary,
        Self::InfiniteReversed,
        Self::W,
        Self::InverseW,
        Self::Logarithmic,
    ];

    /// Whether D decreases with distance, i.e. the depth test is GREATER.
    #[must_use]
    pub fn is_reversed(self) -> bool {
        matches!(
            self,
            Self::Complementary | Self::InfiniteReversed | Self::InverseW
        )
    }

    /// Whether the mapping is defined for `range`: W and logarithmic normalize by f, so they
    /// need a finite far plane; the others have an infinite-far form.
    #[must_use]
    pub fn supports(self, range: VisibleRange) -> bool {
        !(range.is_infinite() && matches!(self, Self::W | Self::Logarithmic))
    }

    /// The depth line (k, B) of the projection matrix that produces this mapping in Vulkan's
    /// [0, 1] (`DESIGN.md` section 1), or `None` for mappings that no projection produces
    /// (W and logarithmic need a per-pixel division or a logarithm; inverse W is reported as
    /// its own kind, see [`Mapping::InverseW`]).
    #[must_use]
    pub fn projection_coefficients(self, range: VisibleRange) -> Option<DepthCoefficients> {
        let zero_to_one = DepthConvention::ZeroToOne;
        match self {
            Self::Standard => Some(DepthCoefficients::standard(range, zero_to_one)),
            Self::Complementary => Some(DepthCoefficients::reversed(range, zero_to_one)),
            Self::InfiniteReversed => VisibleRange::infinite(range.near())
                .ok()
                .map(|infinite| DepthCoefficients::reversed(infinite, zero_to_one)),
            Self::W | Self::InverseW | Self::Logarithmic => None,
        }
    }

    /// Normalized depth at view depth `w`, in f64. NaN where the mapping does not support
    /// `range` ([`Mapping::supports`]).
    #[must_use]
    pub fn depth(self, w: f64, range: VisibleRange) -> f64 {
        let n = range.near();
        let f = range.far();
        match self {
            // f (w - n) / ((f - n) w), written with n/f (0 for an infinite far plane) so that
            // it is also the infinite form 1 - n/w.
            Self::Standard => (w - n) / (w * (1.0 - n / f)),
            Self::Complementary if range.is_infinite() => n / w,
            // `f - w` is exact near the far plane (Sterbenz), where `f / w - 1` or `1 - w / f`
            // would lose the relative accuracy of a D close to 0.
            Self::Complementary => n / w * ((f - w) / (f - n)),
            Self::InfiniteReversed | Self::InverseW => n / w,
            Self::W if range.is_infinite() => f64::NAN,
            Self::W => w / f,
            Self::Logarithmic if range.is_infinite() => f64::NAN,
            Self::Logarithmic => (w / n).ln() / (f / n).ln(),
        }
    }

    /// View depth at normalized depth `d`: the inverse of [`Mapping::depth`]. Outside the
    /// image of `[n, f]` the formula is continued as is (it may return infinity or a
    /// negative value); NaN where the mapping does not support `range`.
    #[must_use]
    pub fn distance(self, d: f64, range: VisibleRange) -> f64 {
        let n = range.near();
        let f = range.far();
        let near_over_far = n / f;
        match self {
            // d = f (w - n) / ((f - n) w)  =>  w = n / ((1 - d) + d n/f). `1 - d` is exact for
            // d in [0.5, 1], where standard depth crowds.
            Self::Standard => n / ((1.0 - d) + d * near_over_far),
            // d = n (f - w) / ((f - n) w)  =>  w = n / (d (1 - n/f) + n/f).
            Self::Complementary => n / (d * (1.0 - near_over_far) + near_over_far),
            Self::InfiniteReversed | Self::InverseW => n / d,
            Self::W if range.is_infinite() => f64::NAN,
            Self::W => d * f,
            Self::Logarithmic if range.is_infinite() => f64::NAN,
            Self::Logarithmic => n * (d * (f / n).ln()).exp(),
        }
    }

    /// `dD/dw` at `w`: negative for reversed mappings. NaN where the mapping does not support
    /// `range`.
    #[must_use]
    pub fn slope(self, w: f64, range: VisibleRange) -> f64 {
        let n = range.near();
        let f = range.far();
        let standard = n / ((1.0 - n / f) * w * w);
        match self {
            Self::Standard => standard,
            Self::Complementary => -standard,
            Self::InfiniteReversed | Self::InverseW => -n / (w * w),
            Self::W if range.is_infinite() => f64::NAN,
            Self::W => 1.0 / f,
            Self::Logarithmic if range.is_infinite() => f64::NAN,
            Self::Logarithmic => 1.0 / (w * (f / n).ln()),
        }
    }

    /// The depth values the mapping takes over `[n, f]`, as `(low, high)`.
    #[must_use]
    pub fn depth_bounds(self, range: VisibleRange) -> (f64, f64) {
        let at_near = self.depth(range.near(), range);
        let at_far = if range.is_infinite() {
            // Every mapping with an infinite form tends to 1 (standard) or 0 (reversed).
            if self.is_reversed() {
                0.0
            } else {
                1.0
            }
        } else {
            self.depth(range.far(), range)
        };
        (at_near.min(at_far), at_near.max(at_far))
    }

    /// View depth reached from `d` by a change of `step` (>= 0) in D: in the direction of
    /// increasing `w` when `farther`, else of decreasing `w`, unless that leaves the mapping's
    /// depth bounds over the range (the far plane of a standard mapping sits at D = 1), in
    /// which case the step goes the other way. This is how both seed 002's "step one stored
    /// value" and seed 000's eq. (7) stay defined at the ends of the range.
    pub(crate) fn displaced_distance(
        self,
        d: f64,
        step: f64,
        farther: bool,
        range: VisibleRange,
    ) -> f64 {
        let (low, high) = self.depth_bounds(range);
        // D grows with w for standard-direction mappings.
        let up = farther != self.is_reversed();
        let preferred = if up { d + step } else { d - step };
        let other = if up { d - step } else { d + step };
        let target = if (low..=high).contains(&preferred) {
            preferred
        } else {
            other
        };
        self.distance(target, range)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range(n: f64, f: f64) -> VisibleRange {
        VisibleRange::new(n, f).expect("valid range")
    }

    #[test]
    fn ends_of_the_range() {
        let r = range(0.5, 8.0);
        let expected = [
            (Mapping::Standard, 0.0, 1.0),
            (Mapping::Complementary, 1.0, 0.0),
            (Mapping::InfiniteReversed, 1.0, 0.0625),
            (Mapping::W, 0.0625, 1.0),
            (Mapping::InverseW, 1.0, 0.0625),
            (Mapping::Logarithmic, 0.0, 1.0),
        ];
        for (mapping, at_near, at_far) in expected {
            assert_eq!(mapping.depth(0.5, r), at_near, "{mapping:?} at n");
            assert_eq!(mapping.depth(8.0, r), at_far, "{mapping:?} at f");
        }
    }

    #[test]
    fn agrees_with_the_projection_lines() {
        let r = range(0.1, 1000.0);
        for mapping in [
            Mapping::Standard,
            Mapping::Complementary,
            Mapping::InfiniteReversed,
        ] {
            let line = mapping.projection_coefficients(r).expect("a projection");
            for w in [0.1, 0.3, 7.0, 999.0] {
                let difference = (line.depth_at(w) - mapping.depth(w, r)).abs();
                assert!(difference < 1e-15, "{mapping:?} at {w}: {difference}");
            }
        }
        for mapping in [Mapping::W, Mapping::InverseW, Mapping::Logarithmic] {
            assert_eq!(mapping.projection_coefficients(r), None);
        }
    }

    #[test]
    fn infinite_far_plane() {
        let r = VisibleRange::infinite(2.0).expect("valid range");
        assert_eq!(Mapping::Standard.depth(4.0, r), 0.5);
        assert_eq!(Mapping::Complementary.depth(4.0, r), 0.5);
        assert_eq!(Mapping::Complementary.distance(0.5, r), 4.0);
        assert!(Mapping::W.depth(4.0, r).is_nan());
        assert!(!Mapping::Logarithmic.supports(r));
        assert_eq!(Mapping::Standard.depth_bounds(r), (0.0, 1.0));
    }

    #[test]
    fn complementary_keeps_relative_accuracy_at_the_far_plane() {
        let r = range(0.1, 1e6);
        let w = 1e6 * (1.0 - 1e-9);
        // 1e6 - w is exact; the rest has a few roundings.
        let expected = 0.1 * (1e6 - w) / ((1e6 - 0.1) * w);
        let cancelling: f64 = 0.1 / (1e6 - 0.1) * (1e6 / w - 1.0);
        assert!((cancelling / expected - 1.0).abs() > 1e-9);
        let depth = Mapping::Complementary.depth(w, r);
        assert!(
            (depth / expected - 1.0).abs() < 1e-12,
            "{depth} vs {expected}"
        );
    }

    #[test]
    fn displacement_turns_back_at_the_far_plane() {
        let r = range(1.0, 10.0);
        let beyond = Mapping::Standard.displaced_distance(1.0, 0.01, true, r);
        assert!(beyond < 10.0);
        let behind = Mapping::Complementary.displaced_distance(0.5, 0.01, true, r);
        assert!(behind > Mapping::Complementary.distance(0.5, r));
    }
}
