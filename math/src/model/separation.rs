//! Storage-only minimum separation (seed 002's precision analysis): how far behind a surface
//! another one must be for the two to land on different stored depth values, when the only
//! error is the storage format's.
//!
//! Seed 002 samples view depth, maps it to the buffer format, steps one representable value
//! and maps back. That is seed 000's eq. (1) without the linearization: the separation is the
//! width, in view depth, of one storage step at D(z). It is the floor below which no vertex
//! arithmetic can go; [`super::Simulation`] measures how far above it the float32 vertex path
//! sits. Two versions: [`min_separation`] takes one step of [`StorageFormat::step_at`] through
//! the exact inverse mapping (no derivative, so a step that is large against the curvature of
//! D, as for D16 far away, stays right); [`min_separation_brute_force`] finds the stored-value
//! bucket around z by bisection on [`StorageFormat::quantize`] alone, an independent check of
//! the step and the inverse.

use super::mapping::Mapping;
use super::{format::StorageFormat, ModelError};
use crate::range::VisibleRange;

/// Checks that `z` is a view depth inside `[n, f]`.
pub(crate) fn check_distance(z: f64, range: VisibleRange) -> Result<(), ModelError> {
    if z.is_finite() && z >= range.near() && z <= range.far() {
        Ok(())
    } else {
        Err(ModelError::DistanceOutsideRange(z))
    }
}

/// Checks that `mapping` is defined on `range`.
pub(crate) fn check_mapping(mapping: Mapping, range: VisibleRange) -> Result<(), ModelError> {
    if mapping.supports(range) {
        Ok(())
    } else {
        Err(ModelError::NeedsFiniteFar(mapping))
    }
}

/// The storage-only minimum separation at view depth `z` (seed 002): the view-space distance
/// `|w(D(z) + step) - z|` covered by one representable step of `format` at `D(z)`, taken
/// towards larger distances (towards smaller ones at the far end of a mapping, where D has no
/// room left). An absolute distance, in the units of the range.
///
/// This is the bucket width: two surfaces closer than it may share a stored value; farther
/// apart they never do (up to the factor 2 between float binades).
///
/// # Errors
///
/// [`ModelError::DistanceOutsideRange`] for a `z` outside `[n, f]`,
/// [`ModelError::NeedsFiniteFar`] for a mapping that needs a finite far plane.
pub fn min_separation(
    mapping: Mapping,
    format: StorageFormat,
    range: VisibleRange,
    z: f64,
) -> Result<f64, ModelError> {
    check_mapping(mapping, range)?;
    check_distance(z, range)?;
    let d = mapping.depth(z, range);
    let step = format.step_at(d);
    Ok((mapping.displaced_distance(d, step, true, range) - z).abs())
}

/// [`min_separation`] at every distance in `distances`, divided by that distance: the relative
/// separation `dz / z` of `DESIGN.md` section 3, ready to plot on log axes.
///
/// # Errors
///
/// As [`min_separation`], for the first distance that fails.
pub fn min_separation_curve(
    mapping: Mapping,
    format: StorageFormat,
    range: VisibleRange,
    distances: &[f64],
) -> Result<Vec<f64>, ModelError> {
    distances
        .iter()
        .map(|&z| min_separation(mapping, format, range, z).map(|dz| dz / z))
        .collect()
}

/// The width in view depth of the set of depths that store the same value as `z`, found by
/// bisection on [`StorageFormat::quantize`] and [`Mapping::depth`] alone (no step size, no
/// inverse mapping). Slow; for tests of [`min_separation`].
///
/// Where the bucket reaches an end of the range the width is cut there.
///
/// # Errors
///
/// As [`min_separation`].
pub fn min_separation_brute_force(
    mapping: Mapping,
    format: StorageFormat,
    range: VisibleRange,
    z: f64,
) -> Result<f64, ModelError> {
    check_mapping(mapping, range)?;
    check_distance(z, range)?;
    let stored = |w: f64| format.quantize(mapping.depth(w, range));
    let value = stored(z);
    let upper = bucket_edge(z, range.far(), |w| stored(w) == value);
    let lower = bucket_edge(z, range.near(), |w| stored(w) == value);
    Ok(upper - lower)
}

/// The last view depth from `inside` towards `limit` for which `same` still holds, assuming
/// `same` holds on one interval around `inside` (true for a monotone mapping): an expanding
/// search for a point where it fails, then bisection down to f64 resolution.
fn bucket_edge(inside: f64, limit: f64, same: impl Fn(f64) -> bool) -> f64 {
    // An infinite far plane is searched up to the largest finite f64.
    let limit = limit.clamp(-f64::MAX, f64::MAX);
    let direction = if limit >= inside { 1.0 } else { -1.0 };
    let mut reach = inside.abs().max(f64::MIN_POSITIVE) * 1e-12;
    let mut bad = loop {
        let candidate = inside + direction * reach;
        if (candidate - limit) * direction >= 0.0 {
            if same(limit) {
                return limit;
            }
            break limit;
        }
        if !same(candidate) {
            break candidate;
        }
        reach *= 2.0;
    };
    let mut good = inside;
    // Halving the interval until it stops shrinking ends in at most ~1100 steps (the f64
    // exponent range plus the mantissa); in practice about 60.
    loop {
        let middle = good + 0.5 * (bad - good);
        if middle == good || middle == bad {
            return good;
        }
        if same(middle) {
            good = middle;
        } else {
            bad = middle;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unorm_separation_is_the_step_over_the_slope() {
        let range = VisibleRange::new(0.1, 1e6).expect("valid range");
        let z = 0.5;
        let dz = min_separation(Mapping::Standard, StorageFormat::D24, range, z)
            .expect("inside the range");
        let linear = StorageFormat::D24.step_at(0.0) / Mapping::Standard.slope(z, range);
        assert!((dz / linear - 1.0).abs() < 1e-5, "{dz} vs {linear}");
    }

    #[test]
    fn brute_force_finds_the_same_bucket() {
        let range = VisibleRange::new(1.0, 100.0).expect("valid range");
        let dz = min_separation(Mapping::W, StorageFormat::D16, range, 37.3).expect("inside");
        let brute = min_separation_brute_force(Mapping::W, StorageFormat::D16, range, 37.3)
            .expect("inside");
        assert!((dz / brute - 1.0).abs() < 1e-9, "{dz} vs {brute}");
    }

    #[test]
    fn outside_the_range_is_an_error() {
        let range = VisibleRange::new(1.0, 100.0).expect("valid range");
        let below = min_separation(Mapping::Standard, StorageFormat::D24, range, 0.5);
        assert_eq!(below, Err(ModelError::DistanceOutsideRange(0.5)));
        let infinite = VisibleRange::infinite(1.0).expect("valid range");
        let w = min_separation(Mapping::W, StorageFormat::D24, infinite, 5.0);
        assert_eq!(w, Err(ModelError::NeedsFiniteFar(Mapping::W)));
    }
}
