//! The depth precision model: how close two surfaces can be and still sort correctly, for
//! every depth mapping and storage format revz deals with, and how much of that the GPU's
//! float32 vertex arithmetic gives away.
//!
//! It exists to make the numbers of `DESIGN.md` section 3 computable (they decide the layer's
//! depth policy: which mapping, and when to promote D16/D24 to D32_SFLOAT) and to give the
//! tester the curves it draws. Three models, from the seeds:
//!
//! | model | seed | question | entry points |
//! |---|---|---|---|
//! | storage-only separation | 002 | how wide is one stored value, in view depth? | [`min_separation`], [`min_separation_curve`] |
//! | average error | 000, eq. (6), (7) | which buffer is better overall? | [`average_error`], [`depth_error`] |
//! | float32 simulation | 001 | which separation does the GPU really resolve? | [`Simulation`], [`simulated_min_separation`], [`simulated_min_separation_curve`] |
//!
//! Building blocks: [`Mapping`] (screen Z, complementary Z, infinite reversed, W, inverse W,
//! logarithmic; `depth`, its inverse `distance`, `slope`), and [`StorageFormat`] (UNORM
//! 16/24/32, IEEE float32, and seed 000's small floats; `quantize`, `step_at`). Distances are
//! view depths `w` (the distance along the view axis, what `w_clip` holds), in the units of
//! the [`VisibleRange`](crate::VisibleRange).
//!
//! `tests/model.rs` reproduces `DESIGN.md` section 3 with this module: near 0.1, far 1e6, a
//! rotated camera at the world origin, precomposed `fl32(P*V)`, 4000 pairs per separation.
//!
//! Separations are absolute from [`min_separation`] and relative (`dz / z`, the unit of
//! `DESIGN.md` section 3) from the curve and simulation functions, so the two kinds of curve
//! can be drawn on the same axes:
//!
//! ```
//! use revz_math::model::{
//!     min_separation_curve, simulated_min_separation_curve, Camera, Mapping, Simulation,
//!     StorageFormat, VertexTransform,
//! };
//! use revz_math::VisibleRange;
//!
//! let range = VisibleRange::new(0.1, 1e6).expect("0 < n < f");
//! let distances = [0.5, 50.0];
//! let floor = min_separation_curve(Mapping::Complementary, StorageFormat::D32F, range, &distances)
//!     .expect("distances inside the range");
//! let simulation = Simulation {
//!     camera: Camera::default(),
//!     range,
//!     mapping: Mapping::Complementary,
//!     format: StorageFormat::D32F,
//!     transform: VertexTransform::Precomposed,
//!     pairs: 500,
//!     seed: 1,
//! };
//! let measured = simulated_min_separation_curve(&simulation, &distances).expect("valid setup");
//! for (storage_only, float32) in floor.iter().zip(&measured) {
//!     // The float32 vertex path can only add error on top of the storage step.
//!     assert!(float32.expect("resolved below 1") >= 0.5 * storage_only);
//! }
//! ```

mod average;
mod format;
mod mapping;
mod separation;
mod simulation;

pub use average::{average_error, depth_error, Sampling, VertexInput};
pub use format::{SmallFloatFormat, StorageFormat, UnormFormat};
pub use mapping::Mapping;
pub use separation::{min_separation, min_separation_brute_force, min_separation_curve};
pub use simulation::{
    separation_grid, simulated_min_separation, simulated_min_separation_curve, Camera, Simulation,
    VertexTransform, DISTANCE_JITTER, WRONG_ORDER_LIMIT,
};

/// Why a model function cannot answer.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ModelError {
    /// A storage format outside the supported bit counts.
    InvalidFormat,
    /// The mapping normalizes by the far plane (W, logarithmic), or the model averages over
    /// `[n, f]`, and the range is infinite.
    NeedsFiniteFar(Mapping),
    /// The simulation needs a projection matrix, and no projection produces this mapping.
    NotAProjection(Mapping),
    /// A distance outside the range the function needs (`[n, f]`; see each function).
    DistanceOutsideRange(f64),
    /// A relative separation that is not finite and positive.
    InvalidSeparation(f64),
    /// No samples or pairs to average over.
    TooFewSamples,
    /// A camera with a non-finite or non-unit pose, or a field of view or aspect ratio
    /// outside its range.
    InvalidCamera,
}

impl std::fmt::Display for ModelError {
    fn fmt(&self, formatter: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::InvalidFormat => formatter.write_str("unsupported storage format"),
            Self::NeedsFiniteFar(mapping) => {
                write!(formatter, "{mapping:?} needs a finite far plane here")
            }
            Self::NotAProjection(mapping) => {
                write!(formatter, "no projection matrix produces {mapping:?}")
            }
            Self::DistanceOutsideRange(distance) => {
                write!(formatter, "distance {distance} outside the usable range")
            }
            Self::InvalidSeparation(separation) => {
                write!(
                    formatter,
                    "separation {separation} is not finite and positive"
                )
            }
            Self::TooFewSamples => formatter.write_str("too few samples"),
            Self::InvalidCamera => formatter.write_str("invalid camera"),
        }
    }
}

impl std::error::Error for ModelError {}
