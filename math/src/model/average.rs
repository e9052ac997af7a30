//! Seed 000's average depth error (Lapidous & Jiao, section 2.1, eq. 6 and 7): one number per
//! mapping, format and sampling distribution, so that buffers can be ranked the way the paper
//! ranks them (complementary Z against Z, W and inverse W at 16, 24 and 32 bits).
//!
//! Eq. (7), the error at view depth `Z_e`, is the view-space distance covered by the larger of
//! the per-vertex and the per-pixel representation errors of D:
//!
//! ```text
//! dZe(Ze) = | Ze(D + max[dDv, dDp]) - Ze(D) |                                     (7)
//! ```
//!
//! - `dDp`, the per-pixel error, is the storage step at D ([`StorageFormat::step_at`]).
//! - `dDv`, the per-vertex error, is the error of D "after computation of normalized device
//!   coordinates" from IEEE float input: taken here as one float32 step at D
//!   ([`float32_ulp`]), i.e. D itself is a float32 when it leaves the vertex stage. This is
//!   the reading that reproduces seed 000's 32-bit statements: a 32-bit integer W buffer and
//!   a float32 inverse W buffer come out "almost identical" (both about `Ze * 2^-23`), and
//!   float32 complementary Z, with `dZe ~ Ze (1 - Ze/f) 2^-23`, "3 times better than W" (the
//!   mean of `Ze (1 - Ze/f)` over `[0, f]` is a third of the mean of `Ze`). With
//!   [`VertexInput::Exact`] the term is left out (storage only).
//! - `Ze(D + e)` steps up in D as eq. (7) writes it, except where `D + e` leaves the values the
//!   mapping takes on `[n, f]` (D = 1 at the far plane of screen Z): there it steps down.
//!   Seed 000 leaves corner cases to the implementation.
//!
//! Eq. (6) averages over a finite set of samples and normalizes by the depth range:
//!
//! ```text
//! mean dZe = sum_{Ze=d..f} dZe(Ze) S(Ze) / ((f - d) sum_{Ze=d..f} S(Ze))          (6)
//! ```
//!
//! with `S` constant ("uniform", `S(d) = S(f)`) or growing linearly from 0 at the near plane
//! ("linearly increasing", `S(d) = 0`). The samples are equally spaced in `Ze` from `n` to `f`
//! inclusive.

use super::format::StorageFormat;
use super::mapping::Mapping;
use super::separation::check_mapping;
use super::ModelError;
use crate::precision::float32_ulp;
use crate::range::VisibleRange;

/// Seed 000's sampling distributions `S(Ze)` for eq. (6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sampling {
    /// The same number of samples at every distance (`S(d) = S(f)`).
    Uniform,
    /// Samples growing linearly with distance from none at the near plane (`S(d) = 0`).
    LinearlyIncreasing,
}

/// Whether eq. (7) includes the per-vertex error `dDv`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VertexInput {
    /// D leaves the vertex stage as a float32: `dDv` is one float32 step at D (seed 000).
    Float32,
    /// D is exact before storage: storage error only.
    Exact,
}

/// Seed 000's eq. (6) average normalized depth error of `mapping` stored in `format` over
/// `range`, from `samples` equally spaced view depths, with eq. (7) for the error at each.
/// Dimensionless (divided by `f - n`).
///
/// # Errors
///
/// [`ModelError::NeedsFiniteFar`] for an infinite range (eq. 6 averages over `[n, f]`),
/// [`ModelError::TooFewSamples`] for fewer than 2 samples.
pub fn average_error(
    mapping: Mapping,
    format: StorageFormat,
    range: VisibleRange,
    sampling: Sampling,
    vertex: VertexInput,
    samples: usize,
) -> Result<f64, ModelError> {
    check_mapping(mapping, range)?;
    if range.is_infinite() {
        return Err(ModelError::NeedsFiniteFar(mapping));
    }
    if samples < 2 {
        return Err(ModelError::TooFewSamples);
    }
    let n = range.near();
    let f = range.far();
    let last = (samples - 1) as f64;
    let mut weighted_error = 0.0;
    let mut total_weight = 0.0;
    for index in 0..samples {
        let fraction = index as f64 / last;
        let z = if index + 1 == samples {
            f
        } else {
            n + (f - n) * fraction
        };
        let weight = match sampling {
            Sampling::Uniform => 1.0,
            Sampling::LinearlyIncreasing => fraction,
        };
        weighted_error += error_at(mapping, format, range, vertex, z) * weight;
        total_weight += weight;
    }
    Ok(weighted_error / ((f - n) * total_weight))
}

/// Seed 000's eq. (7) at view depth `z`, in the units of the range.
///
/// # Errors
///
/// [`ModelError::NeedsFiniteFar`] for a mapping that needs a finite far plane,
/// [`ModelError::DistanceOutsideRange`] for a `z` outside `[n, f]`.
pub fn depth_error(
    mapping: Mapping,
    format: StorageFormat,
    range: VisibleRange,
    vertex: VertexInput,
    z: f64,
) -> Result<f64, ModelError> {
    check_mapping(mapping, range)?;
    super::separation::check_distance(z, range)?;
    Ok(error_at(mapping, format, range, vertex, z))
}

fn error_at(
    mapping: Mapping,
    format: StorageFormat,
    range: VisibleRange,
    vertex: VertexInput,
    z: f64,
) -> f64 {
    let d = mapping.depth(z, range);
    let per_pixel = format.step_at(d);
    let per_vertex = match vertex {
        VertexInput::Float32 => float32_ulp(d),
        VertexInput::Exact => 0.0,
    };
    // Eq. (7) adds the error to D: towards larger w for standard-direction mappings, smaller
    // for reversed ones.
    let farther = !mapping.is_reversed();
    (mapping.displaced_distance(d, per_pixel.max(per_vertex), farther, range) - z).abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_w_buffer_error_is_the_step() {
        // W buffer, D = w / f: dZe = f * step everywhere, so the normalized mean is
        // f * step / (f - n) under any sampling.
        let range = VisibleRange::new(1.0, 1000.0).expect("valid range");
        for sampling in [Sampling::Uniform, Sampling::LinearlyIncreasing] {
            let mean = average_error(
                Mapping::W,
                StorageFormat::D16,
                range,
                sampling,
                VertexInput::Exact,
                1001,
            )
            .expect("valid");
            let expected = 1000.0 / 65535.0 / 999.0;
            assert!((mean / expected - 1.0).abs() < 1e-9, "{mean} vs {expected}");
        }
    }

    #[test]
    fn needs_a_finite_range_and_samples() {
        let infinite = VisibleRange::infinite(1.0).expect("valid range");
        let finite = VisibleRange::new(1.0, 10.0).expect("valid range");
        let mean = |range, samples| {
            average_error(
                Mapping::Complementary,
                StorageFormat::D24,
                range,
                Sampling::Uniform,
                VertexInput::Float32,
                samples,
            )
        };
        assert!(mean(infinite, 100).is_err());
        assert_eq!(mean(finite, 1), Err(ModelError::TooFewSamples));
        assert!(mean(finite, 2).is_ok());
    }
}
