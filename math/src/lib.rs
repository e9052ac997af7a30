//! The depth math of revz: classify the clip-space matrix an application pushes and rewrite it
//! to reversed depth, in f64, with no Vulkan in it.
//!
//! `DESIGN.md` section 1 in one formula: a perspective clip-space transform `M` (P, P*V or
//! P*V*M, rows r0..r3, `clip = M * v`) has a depth row on its w row, `r2 = k * r3 + B * e3`, so
//! its normalized depth is `D(w) = k + B / w`. The crate
//!
//! - reads the 16 float32 values in the member's storage order ([`read_clip_transform`]),
//! - classifies the matrix ([`classify`](fn@classify)): standard perspective with its recovered (k, B) and
//!   visible range (n, f, f possibly infinite), orthographic/affine, already reversed, or not
//!   a projection,
//! - rewrites a standard perspective to complementary or infinite reversed depth, and an
//!   orthographic one to its exact finite reversal ([`rewrite`](fn@rewrite)): the new depth row is
//!   `k' * r3 + B' * e3` computed in f64, never `r3 - r2`,
//! - writes the result back, each entry rounded once ([`write_clip_transform`]).
//!
//! [`camera`] gives the matrices of one camera one range: far objects lose B to float32
//! rounding, so a table of cameras ([`Cameras`]), keyed by depth line within its error bounds
//! ([`DepthLine`]), hands every matrix the range of its camera's best-conditioned matrix.
//!
//! [`precision`] holds the float32 evaluation and error floor that tests (and the tester's
//! depth read-back) compare against. [`model`] is the precision model behind `DESIGN.md`
//! section 3: storage-only minimum separation, seed 000's average error, and a float32
//! simulation of the vertex path, for every mapping and depth format.
//!
//! ```
//! use glam::{dcamera::rh::proj::vulkan, DVec4};
//! use revz_math::{classify, read_clip_transform, rewrite, write_clip_transform};
//! use revz_math::{Classification, DepthConvention, Storage, Target};
//!
//! let pushed = vulkan::perspective(1.0, 16.0 / 9.0, 0.1, 1000.0).as_mat4().to_cols_array();
//! let m = read_clip_transform(&pushed, Storage::ColumnMajor);
//! let classification = classify(&m, DepthConvention::ZeroToOne);
//! let Classification::Perspective { range, .. } = classification else { unreachable!() };
//! assert!((range.near() / 0.1 - 1.0).abs() < 1e-6 && (range.far() / 1000.0 - 1.0).abs() < 1e-2);
//! let reversed = rewrite(&m, &classification, Target::Infinite).expect("a standard perspective");
//! assert_eq!(reversed.row(2), DVec4::new(0.0, 0.0, 0.0, range.near()));
//! let _bytes_to_push: [f32; 16] = write_clip_transform(&reversed, Storage::ColumnMajor);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![deny(clippy::unwrap_used)]

pub mod camera;
mod classify;
mod matrix;
pub mod model;
pub mod precision;
mod range;
mod rewrite;
pub mod shader_fit;

pub use camera::{CameraMatch, Cameras, DepthLine, MAX_CAMERAS, TRUSTED_B_ERROR};
pub use classify::{
    classify, fit_depth_row, Classification, DepthFit, Rejection, AFFINE_W_TOLERANCE,
    RESIDUAL_TOLERANCE,
};
pub use matrix::{from_rows, read_clip_transform, write_clip_transform, Storage, E3};
pub use range::{DepthCoefficients, DepthConvention, DepthDirection, RangeError, VisibleRange};
pub use rewrite::{reversed_coefficients, reversed_depth_row, rewrite, rewrite_into, Target};
