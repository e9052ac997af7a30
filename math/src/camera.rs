//! One camera, one range: a small table of the cameras seen in the pushed matrices, so that every
//! matrix of one camera gets one visible range, the one of the best-conditioned matrix seen.
//!
//! This module owns the depth line of a float32 clip transform with bounds on its rounding
//! error ([`DepthLine`]), the trust threshold ([`TRUSTED_B_ERROR`]) and the table ([`Cameras`]).
//!
//! Why: an application pushes one float32 `M = P * V * Model` per object. Its depth row is
//! `r2 = k * r3 + B * e3` with the camera's (k, B), but B is recovered as `r2.w - k * r3.w`, and
//! `r3.w` is the object origin's view distance d. For d much larger than n the rounding of
//! `r2.w` and `r3.w` (about u d) swamps B (about n): in the `deep-range` scene (n = 1e-3) the
//! cells at 1e2..1e3 have B exactly 0. Each matrix's own (n, f) is then noise, and two objects
//! at the same w get different depth scales. The objects of one camera share (k, B), so the
//! table keeps, per camera, the line with the smallest relative error of B, and hands its range
//! to every matrix whose line agrees with it within the error bounds.
//!
//! # The key: convention and depth line, not the w row's direction
//!
//! A camera is (convention, k, B). The w row's direction is not part of the key: with rotated
//! model matrices (and a camera that turns between frames) r3.xyz differs from object to object
//! while k and B do not. (The issue suggested keying on the direction; this is a deliberate
//! deviation.) Two cameras with the same (k, B) are therefore one camera here, which is what the
//! layer needs: they render the same depth range.
//!
//! # Error bounds (u = 2^-24)
//!
//! Let `M*` be the application's exact transform, `r2* = k r3* + B e3`, and `M = M* + Delta` the
//! float32 matrix, rows `r2 = r2* + d2`, `r3 = r3* + d3`. With `e = (d2 - k d3).xyz`,
//! `r2.xyz = k r3.xyz + e`, so the least-squares `k^ = <r2.xyz, r3.xyz> / |r3.xyz|^2` has
//! `k^ - k = <e, r3.xyz> / |r3.xyz|^2`: only e's part along r3.xyz moves k, and its orthogonal
//! part is the fit's residual vector `r2.xyz - k^ r3.xyz`. Exactly (in reals),
//!
//! ```text
//! B^ = r2.w - k^ r3.w = B + d2.w - k d3.w - (k^ - k) r3.w
//! ```
//!
//! - Entries each rounded once (composed in f64): `|d2_i| <= u |r2*_i|`, `|d3_i| <= u |r3*_i|`,
//!   so `|k^ - k| <= 2u |k|` and `|B^ - B| <= u (|r2.w| + 3 |k r3.w|)` (first order).
//! - Composed in float32: glam's f32 projection has its own k within 3u (`f - n`, the
//!   reciprocal, the product) and B within 4u, and every product entry is a dot product within
//!   `gamma_m * sum |a_i b_i|` (m terms, `gamma_m` about m u). For `P * (V * Model)` the error
//!   of `V * Model` is an error of the object's placement, which does not leave the line (any
//!   affine X gives `P * X` the line of P), so only the last product counts: one rounding of
//!   each xyz entry of r2 (r3 is exact), two of `r2.w`. That is `|k^ - k| <= 4u |k|` and
//!   `|B^ - B| <= 4u |B| + u (2 |k r3.w| + |r2.w|) <= u (5 |r2.w| + 6 |k r3.w|)` (the
//!   constructor's error in k cancels in B^, since `r2.w` carries the same rounded k), first
//!   order. For `(P * V) * Model` (glam's `P * V * M`) the xyz entries pass through `P * V`
//!   (1u) and a 3-term sum (3u): `|k^ - k|` up to about `7u |k|`; for its w column see the
//!   limitation below.
//!
//! The bounds, 8u where the float32 products need up to 7u (4 times the once-rounded 2u):
//!
//! ```text
//! k_error = |r2.xyz - k^ r3.xyz| / |r3.xyz| + 8u |k^|
//! b_error = 8u (|r2.w| + |k^ r3.w|) + k_error |r3.w|
//! ```
//!
//! The residual term of `k_error` is e's orthogonal part: rounding that is larger than assumed
//! (longer float32 chains, non-uniform scale) shows up there, and rounding errors have no
//! preferred direction, so the parallel part is of the same size. The f64 evaluation of the fit
//! adds a few 2^-53 relative, far inside the 8u terms. `tests/cameras.rs` measures the ratios
//! error / bound over random cameras and objects (10 n to 1e6 n): for B at most 0.14 (f64,
//! rounded once), 0.10 (`P * (V * Model)`) and 0.26 (`(P * V) * Model`, eye within the nearest
//! object's distance of the origin); for k at most 0.23, 0.44 and 0.56. (Tightening 8u to 4u
//! would leave the float32 k bound with no margin, and buy a factor 2 in how far from the
//! camera a line is trusted.)
//!
//! Limitation, float32 `(P * V) * Model` with the camera at distance E from the world origin:
//! `P * V` has a translation of about `|k| E`, rounded to about `u |k| E`, and the model
//! translation (about E) cancels it in value but not in error: B carries an extra error of up
//! to about `10u |k| E`, which the product (whose entries are of the size of the object's view
//! distance d) does not show. The bounds hold for E below d (measured error / bound at most 0.3
//! there); the ratio grows as E / d beyond (up to 1.4 for E in [d, 10 d), 13 in [10 d, 100 d),
//! 130 in [100 d, 1000 d)). Such a line is noisier than it says: matrices of one camera may
//! disagree and open cameras of their own, each still within about `10u |k| E / |B|`
//! (relative) of the true B; the rest of the table works unchanged. Composing in f64, or as
//! `P * (V * Model)`, avoids it.
//!
//! # Trust
//!
//! A line is trusted alone when `b_error / |B| <= TRUSTED_B_ERROR` (see the constant). A line
//! matching no camera starts one when its computed range is valid and either it is trusted or
//! its direction is standard; a matching line becomes the camera's line when its relative error
//! is smaller (in a table that pins ranges, [`Cameras::pinning_ranges`], a trusted camera keeps
//! its range while its line improves). Any line (a far object, B lost to rounding, even B = 0)
//! is matched against the known cameras first: the true (k, B) lies within the error bounds of
//! both lines, so a line of the camera agrees with the camera's best line however large its own
//! error.
//!
//! Why untrusted standard lines start (provisional) cameras: some applications push no matrix
//! from which n can be had at all. `mars-patch` pushes one P * V built around a world origin
//! 3390 km away, where float32 cannot hold B (0.2) next to `r2.w` (3.4e6, ulp 0.25). All its
//! draws share that line, so any n of the right sign stores consistent depths (n only scales
//! them, and moves the near clip plane by the same fraction); refusing it would send them to
//! the flip path and its standard-depth errors (3 % wrong pixels instead of none). What needs
//! trust is what a wrong sign would break: a line that looks reversed (B > 0 from rounding)
//! never makes a reversed camera unless it is trusted (the application's convention is
//! decided from reversed projections), and B = 0 gives no range: both are
//! [`CameraMatch::Untrusted`], and their draws take the flip path.
//!
//! Hot-path use: fixed-size storage, no allocation, no panics.

use glam::{DMat4, DVec4};

use crate::classify::{AFFINE_W_TOLERANCE, RESIDUAL_TOLERANCE};
use crate::matrix::Storage;
use crate::precision::F32_UNIT_ROUNDOFF;
use crate::range::{DepthCoefficients, DepthConvention, DepthDirection, VisibleRange};

/// How many cameras a [`Cameras`] table holds; the least recently used one makes room.
///
/// A frame has a main camera, a few shadow or reflection views and a few screen passes; 8 covers
/// that with room to spare while a linear scan stays cheaper than hashing.
pub const MAX_CAMERAS: usize = 8;

/// Largest relative error bound of B (`b_error / |B|`) for a line to be trusted alone: 0.5.
///
/// Where it comes from (changed from 1e-3 once the layer used it on the tester's scenes):
///
/// - What an error in B does. The camera's range only sets the scale of its reversed depths
///   (`n / w`, or complementary) and where its near clip plane is: every matrix of the camera
///   gets the same range, so their order, and so every depth test between them, is kept. An
///   error of B moves the near clip plane by the same fraction of n and scales the depths
///   uniformly: nothing else. What must never happen is a sign error (B = 0 or the wrong
///   direction), which `b_error / |B| <= 0.5` rules out with room: B is then within a factor
///   of 1.5 by the bound, and the bound is pessimistic (measured errors are 0.1 to 0.3 of it).
/// - Who must be able to start a camera. For a once-rounded [0, 1] matrix, `|B| = k n` and
///   `b_error` is about `24u k d`, so `b_error / |B|` is about `1.4e-6 d / n`. With 1e-3 only
///   objects within 700 n could, and scenes whose every matrix is a P * V seen from far away
///   (`sloped-plane`: the camera 1.1e5 n from the origin its one matrix is built around) never
///   had a camera, so their draws lost the precise path. With 0.5 objects within about
///   3.6e5 n can; farther ones (B lost to rounding: the `deep-range` cells beyond 1e5 n) still
///   borrow the camera's range, and a better line replaces a camera's as soon as one is seen.
/// - Cameras stay apart by k first (k errors are about 1e-6 relative; k = f / (f - n) differs
///   between cameras unless their f / n agree), then by B within both lines' bounds: two
///   cameras of the same f / n whose n differ by less than the sum of their lines' bounds are
///   one camera until a better line separates them.
pub const TRUSTED_B_ERROR: f64 = 0.5;

/// Multiple of u in the rounding terms of the bounds (module docs: 4 times the once-rounded
/// 2u, for float32 products).
const ROUNDING: f64 = 8.0 * F32_UNIT_ROUNDOFF;

/// The depth line of one float32 clip transform with bounds on its rounding error: the true
/// (k, B) of the application's camera is within `k_error` of `k` and within `b_error` of `b`
/// (module docs for the derivation and the one case where it does not hold).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthLine {
    /// The fitted multiple of the w row in the depth row.
    pub k: f64,
    /// The fitted constant term of the depth row, `r2.w - k * r3.w`.
    pub b: f64,
    /// Bound on `|k - k_true|`.
    pub k_error: f64,
    /// Bound on `|b - b_true|`.
    pub b_error: f64,
}

impl DepthLine {
    /// The depth line of `m` (the f64 values of the float32 matrix, `clip = m * v`).
    ///
    /// `None` where an entry is not finite, the w row is zero or w does not vary (affine, per
    /// [`AFFINE_W_TOLERANCE`]), or the depth row is not on the w row within
    /// [`RESIDUAL_TOLERANCE`]: the cases [`crate::classify`](fn@crate::classify) does not call a projection or
    /// calls orthographic. A line with B = 0 or an invalid range is returned: it may still
    /// belong to a known camera.
    #[must_use]
    pub fn of(m: &DMat4) -> Option<Self> {
        if !m.is_finite() {
            return None;
        }
        Self::of_rows(m.row(2), m.row(3))
    }

    /// [`Self::of`] the matrix stored as `values` in `storage` order
    /// ([`crate::read_clip_transform`]), reading only its depth and w rows (the same f64
    /// values, so the same bits): the per-push path.
    #[must_use]
    pub fn of_stored(values: &[f32; 16], storage: Storage) -> Option<Self> {
        if !values.iter().all(|v| v.is_finite()) {
            return None;
        }
        // Entry (row, column) of M: column-major storage holds it at column * 4 + row.
        let at = |row: usize, column: usize| {
            f64::from(match storage {
                Storage::ColumnMajor => values[column * 4 + row],
                Storage::RowMajor => values[row * 4 + column],
            })
        };
        let row = |r: usize| DVec4::new(at(r, 0), at(r, 1), at(r, 2), at(r, 3));
        Self::of_rows(row(2), row(3))
    }

    /// Whether the matrix stored as `values` surely has a line ([`Self::of_stored`]) that
    /// agrees with this one ([`Self::agrees_with`]) and does not improve it (its
    /// [`Self::relative_b_error`] is not below this line's): what the same-camera shortcut
    /// asks of every pushed matrix, answered without a square root or a division.
    ///
    /// `true` implies all three (each bound is met with a relative margin of 1e-6; the f64
    /// rounding of these sums and of the line's own is about 1e-15 of their terms, against
    /// bounds of at least 5e-7 of them); `false` says nothing, and the caller
    /// computes the line. How: with `e = d - k w` for this line's `k` (`d`, `w` the depth and w
    /// rows' xyz), the matrix's own `k'` is within `|e.w| / |w|^2` of `k`, its B within
    /// `|d.w - k w.w - B| + |k' - k| |w.w|` of this B, its error bounds at least their rounding
    /// terms, and its off-line part at most `|e|`; each test below is one of these bounds
    /// multiplied through by `|w|^2`.
    #[must_use]
    #[inline]
    pub fn surely_holds(&self, values: &[f32; 16], storage: Storage) -> bool {
        // Entries far from overflow and underflow in the products below.
        const LARGEST: f32 = 1e18;
        const MARGIN: f64 = 1.0 - 1e-6;
        // |v| <= LARGEST for all 16 (the full search refuses a matrix with any entry not
        // finite), without a branch per entry: a compare of the magnitude's bits (a NaN's
        // exceed every finite value's and infinity's) that vectorizes.
        let too_large = values.iter().fold(false, |any, v| {
            any | ((v.to_bits() & 0x7fff_ffff) > LARGEST.to_bits())
        });
        if too_large {
            return false;
        }
        let v = |i: usize| f64::from(values[i]);
        let (d, w) = match storage {
            Storage::ColumnMajor => (
                DVec4::new(v(2), v(6), v(10), v(14)),
                DVec4::new(v(3), v(7), v(11), v(15)),
            ),
            Storage::RowMajor => (
                DVec4::new(v(8), v(9), v(10), v(11)),
                DVec4::new(v(12), v(13), v(14), v(15)),
            ),
        };
        let (d_xyz, w_xyz) = (d.truncate(), w.truncate());
        let w2 = w_xyz.length_squared();
        let a = w.w.abs();
        // Not affine (with room), and |w|^2 far from underflow.
        if !(w2 >= 1e-18 && w2 > 4.0 * (AFFINE_W_TOLERANCE * a) * (AFFINE_W_TOLERANCE * a)) {
            return false;
        }
        let e = d_xyz - self.k * w_xyz;
        // The residual: |d - k' w| <= |e| <= RESIDUAL_TOLERANCE |d| / 2.
        if e.length_squared()
            > 0.25 * (RESIDUAL_TOLERANCE * RESIDUAL_TOLERANCE) * d_xyz.length_squared()
        {
            return false;
        }
        // |k' - k| W = q; |k'| W >= |k| W - q.
        let q = e.dot(w_xyz).abs();
        let k_lo_w = (self.k.abs() * w2 - q).max(0.0);
        // (2): |k' - k| <= k_error + k'_error, with k'_error >= ROUNDING |k'|.
        if q > MARGIN * (self.k_error * w2 + ROUNDING * k_lo_w) {
            return false;
        }
        // (3): |B' - B| <= b_error + B'_error, with B'_error >= ROUNDING (|d.w| + 2 |k'| |w.w|).
        let c0 = (d.w - self.k * w.w - self.b).abs();
        let b_distance_w = c0 * w2 + q * a;
        let own_b_error_w = ROUNDING * (d.w.abs() * w2 + 2.0 * k_lo_w * a);
        if b_distance_w > MARGIN * (self.b_error * w2 + own_b_error_w) {
            return false;
        }
        // (4): B'_error / |B'| >= b_error / |B|, with |B'| <= |B| + |B' - B|, multiplied by
        // |B|. Where B = 0 this line's relative error is infinite, which no matrix is surely
        // at least: no.
        let b = self.b.abs();
        b > 0.0 && MARGIN * own_b_error_w * b >= self.b_error * (b * w2 + b_distance_w)
    }

    /// The line of a matrix with these (finite) depth and w rows.
    fn of_rows(depth_row: DVec4, w_row: DVec4) -> Option<Self> {
        let w_xyz_length = w_row.truncate().length();
        // Affine, as classify decides it; also the zero w row (0 <= 0). The entries are finite.
        if w_xyz_length <= AFFINE_W_TOLERANCE * w_row.w.abs() {
            return None;
        }
        // `fit_depth_row`'s arithmetic, with the off-line part computed once for the residual
        // and the misfit (the same operations: the same bits).
        let (depth_xyz, w_xyz) = (depth_row.truncate(), w_row.truncate());
        let k = depth_xyz.dot(w_xyz) / w_xyz.length_squared();
        let depth_xyz_length = depth_xyz.length();
        let off_line = (depth_xyz - k * w_xyz).length();
        let residual = if depth_xyz_length == 0.0 {
            0.0
        } else {
            off_line / depth_xyz_length
        };
        let b = depth_row.w - k * w_row.w;
        if !(k.is_finite() && b.is_finite() && residual.is_finite()) {
            return None;
        }
        if residual > RESIDUAL_TOLERANCE {
            return None;
        }
        let misfit = off_line / w_xyz_length;
        let k_error = misfit + ROUNDING * k.abs();
        let b_error =
            ROUNDING * (depth_row.w.abs() + (k * w_row.w).abs()) + k_error * w_row.w.abs();
        let line = Self {
            k,
            b,
            k_error,
            b_error,
        };
        (k_error.is_finite() && b_error.is_finite()).then_some(line)
    }

    /// `b_error / |b|`, the relative error of B (and, to 8u, of the near plane); `+inf` when
    /// `b == 0`.
    #[must_use]
    pub fn relative_b_error(&self) -> f64 {
        if self.b == 0.0 {
            f64::INFINITY
        } else {
            self.b_error / self.b.abs()
        }
    }

    /// Whether the line determines B alone: `relative_b_error() <= TRUSTED_B_ERROR`.
    #[must_use]
    pub fn is_trusted(&self) -> bool {
        self.relative_b_error() <= TRUSTED_B_ERROR
    }

    /// Whether both lines can be the same true line: `|dk| <= k_error` summed and
    /// `|db| <= b_error` summed.
    #[must_use]
    pub fn agrees_with(&self, other: &DepthLine) -> bool {
        (self.k - other.k).abs() <= self.k_error + other.k_error
            && (self.b - other.b).abs() <= self.b_error + other.b_error
    }

    /// The line's (k, B).
    #[must_use]
    pub fn coefficients(&self) -> DepthCoefficients {
        DepthCoefficients {
            k: self.k,
            b: self.b,
        }
    }
}

/// What the table says about one matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraMatch {
    /// The matrix belongs to camera `index`; `range` and `direction` are that camera's (from
    /// its best line).
    Camera {
        /// The camera's slot, `< MAX_CAMERAS`. A slot is reused after eviction, which is
        /// reported as `changed`.
        index: usize,
        /// The camera's visible range.
        range: VisibleRange,
        /// Whether the camera renders standard or reversed depth.
        direction: DepthDirection,
        /// True when this observation created the camera (possibly in an evicted slot) or
        /// improved its line: state derived from the camera's range may be stale (a pinning
        /// table, [`Cameras::pinning_ranges`], keeps a trusted range as it was).
        changed: bool,
    },
    /// A perspective depth line that matches no camera and cannot be trusted alone.
    Untrusted,
    /// Not a perspective transform (affine or orthographic, or not a projection):
    /// [`crate::classify`](fn@crate::classify) says what it is.
    NotPerspective,
}

/// One camera: its best line and what follows from it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Entry {
    convention: DepthConvention,
    line: DepthLine,
    range: VisibleRange,
    direction: DepthDirection,
    /// `Cameras::clock` at the last match: larger is more recent.
    last_used: u64,
}

/// The cameras seen so far, at most [`MAX_CAMERAS`], least recently used evicted first.
#[derive(Clone, Debug, Default)]
pub struct Cameras {
    entries: [Option<Entry>; MAX_CAMERAS],
    clock: u64,
    /// A camera keeps the range of the first trusted line it had ([`Cameras::pinning_ranges`]).
    pins_ranges: bool,
}

impl Cameras {
    /// An empty table.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// This table with ranges pinned: a camera whose line is trusted keeps its range when a
    /// better line of it is seen (the line, which matching and [`Cameras::merge`] read, still
    /// becomes the better one). A recording's table: every draw of one camera in a command
    /// buffer then stores depth on one line, so a depth pre-pass drawn in any order and the
    /// `EQUAL` (or `LESS_OR_EQUAL`) pass after it agree to the bit; the better range reaches
    /// the recordings begun after the next submission, through the device's table (which does
    /// not pin) merging this one. The price: until then, the camera's near plane is within its
    /// first trusted line's error bound of the true one (relative `1.4e-6 d / n` for a first
    /// object at distance `d`: `TRUSTED_B_ERROR`'s notes).
    #[must_use]
    pub fn pinning_ranges(self) -> Self {
        Self {
            pins_ranges: true,
            ..self
        }
    }

    /// Finds the camera of `m` under the pipeline's `convention`, learning from it: a matching
    /// line with a smaller relative error of B becomes the camera's line, and a trusted line
    /// that matches no camera starts one. Never panics.
    pub fn observe(&mut self, m: &DMat4, convention: DepthConvention) -> CameraMatch {
        match DepthLine::of(m) {
            Some(line) => self.observe_line(line, convention),
            None => CameraMatch::NotPerspective,
        }
    }

    /// [`Cameras::observe`] for a line already fitted.
    pub fn observe_line(&mut self, line: DepthLine, convention: DepthConvention) -> CameraMatch {
        self.clock = self.clock.wrapping_add(1);
        // A line's (direction, range), where it may become a camera's line.
        // Untrusted lines of the standard direction are stored too, provisionally (module
        // docs, "Trust"): a better line replaces them as soon as one is seen.
        let storable = |line: &DepthLine| {
            let (direction, range) = line.coefficients().visible_range(convention).ok()?;
            (line.is_trusted() || direction == DepthDirection::Standard)
                .then_some((direction, range))
        };
        if let Some(index) = self.matching(&line, convention) {
            let (clock, pins_ranges) = (self.clock, self.pins_ranges);
            let Some(entry) = self.entries.get_mut(index).and_then(Option::as_mut) else {
                return CameraMatch::Untrusted;
            };
            entry.last_used = clock;
            let mut changed = false;
            if line.relative_b_error() < entry.line.relative_b_error() {
                if let Some((direction, range)) = storable(&line) {
                    // A provisional (untrusted) range is replaced even in a pinning table: it
                    // may be off by more than the trusted bound (module docs, "Trust").
                    if !(pins_ranges && entry.line.is_trusted()) {
                        entry.range = range;
                        entry.direction = direction;
                    }
                    entry.line = line;
                    changed = true;
                }
            }
            return CameraMatch::Camera {
                index,
                range: entry.range,
                direction: entry.direction,
                changed,
            };
        }
        let Some((direction, range)) = storable(&line) else {
            return CameraMatch::Untrusted;
        };
        let index = self.free_slot();
        if let Some(slot) = self.entries.get_mut(index) {
            *slot = Some(Entry {
                convention,
                line,
                range,
                direction,
                last_used: self.clock,
            });
        }
        CameraMatch::Camera {
            index,
            range,
            direction,
            changed: true,
        }
    }

    /// Takes camera `index` of `from` (its line, range and direction) into this table as its
    /// most recently used camera, in slot `into` (a camera of this table it replaces) or in a
    /// free (else the least recently used) slot; returns the slot. `None` where `from` has no
    /// such camera or `into` is no slot. Never allocates.
    pub fn adopt(&mut self, from: &Cameras, index: usize, into: Option<usize>) -> Option<usize> {
        let entry = (*from.entries.get(index)?)?;
        let slot = into.unwrap_or_else(|| self.free_slot());
        self.clock = self.clock.wrapping_add(1);
        let place = self.entries.get_mut(slot)?;
        *place = Some(Entry {
            last_used: self.clock,
            ..entry
        });
        Some(slot)
    }

    /// Marks camera `index` used now (as a match by [`Cameras::observe_line`] does), for a
    /// caller that knows a line matches it without searching.
    pub fn touch(&mut self, index: usize) {
        self.clock = self.clock.wrapping_add(1);
        let clock = self.clock;
        if let Some(Some(entry)) = self.entries.get_mut(index) {
            entry.last_used = clock;
        }
    }

    /// Camera `index`: its range, direction, convention and best line; `None` for an empty slot
    /// or an index `>= MAX_CAMERAS`.
    #[must_use]
    pub fn camera(
        &self,
        index: usize,
    ) -> Option<(VisibleRange, DepthDirection, DepthConvention, DepthLine)> {
        let entry = self.entries.get(index)?.as_ref()?;
        Some((entry.range, entry.direction, entry.convention, entry.line))
    }

    /// The camera `line` belongs to under `convention` (the most recently used agreeing one),
    /// without learning from it.
    #[must_use]
    pub fn find(&self, line: &DepthLine, convention: DepthConvention) -> Option<usize> {
        self.matching(line, convention)
    }

    /// How many cameras the table holds.
    #[must_use]
    pub fn len(&self) -> usize {
        self.entries.iter().flatten().count()
    }

    /// Whether the table holds no camera.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.entries.iter().all(Option::is_none)
    }

    /// Learning across command buffers: every camera of `other` is observed in `self`, oldest
    /// first, so that per camera the better-conditioned line of the two is kept and cameras only
    /// `other` knows are added (evicting `self`'s least recently used). `other`'s cameras count
    /// as more recent than all of `self`'s: `other` is meant to be the newer record (a command
    /// buffer merged into a longer-lived table). Returns whether any camera was created or
    /// improved, i.e. whether a slot's range may have changed. Never allocates.
    pub fn merge(&mut self, other: &Cameras) -> bool {
        let mut order = [(0u64, 0usize); MAX_CAMERAS];
        let mut count = 0;
        for (index, entry) in other.entries.iter().enumerate() {
            if let (Some(entry), Some(place)) = (entry, order.get_mut(count)) {
                *place = (entry.last_used, index);
                count += 1;
            }
        }
        let order = order.get_mut(..count).unwrap_or_default();
        order.sort_unstable();
        let mut changed = false;
        for &(_, index) in order.iter() {
            if let Some(Some(entry)) = other.entries.get(index) {
                if let CameraMatch::Camera { changed: true, .. } =
                    self.observe_line(entry.line, entry.convention)
                {
                    changed = true;
                }
            }
        }
        changed
    }

    /// Forgets every camera.
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// The most recently used camera of `convention` whose line agrees with `line`.
    fn matching(&self, line: &DepthLine, convention: DepthConvention) -> Option<usize> {
        // A plain loop (the iterator chain's form took twice the instructions on the path of a
        // new camera per push): the most recently used agreeing camera, the last of equals.
        let mut best: Option<(usize, u64)> = None;
        for (index, entry) in self.entries.iter().enumerate() {
            let Some(entry) = entry else { continue };
            if entry.convention == convention
                && entry.line.agrees_with(line)
                && best.is_none_or(|(_, used)| entry.last_used >= used)
            {
                best = Some((index, entry.last_used));
            }
        }
        best.map(|(index, _)| index)
    }

    /// The first empty slot, or the least recently used one (the first of equals).
    fn free_slot(&self) -> usize {
        let (mut oldest, mut used) = (0, u64::MAX);
        for (index, entry) in self.entries.iter().enumerate() {
            let Some(entry) = entry else { return index };
            if entry.last_used < used {
                (oldest, used) = (index, entry.last_used);
            }
        }
        oldest
    }
}
