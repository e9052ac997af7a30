//! The precision model (`revz_math::model`) beside the measurements: for each mode and depth
//! format, the float32 simulation of `plane-stack`'s camera (position, rotation, field of view,
//! aspect, near and far; P * V precomposed, as the scene pushes it) gives the minimum relative
//! separation the GPU should resolve at each distance, and the storage-only model the floor
//! the format alone allows.
//!
//! Modes map to the model's mappings: `none` and `flip` compute standard depth (flip only
//! stores 1 - D, which keeps D's rounding: the same float grid near 1, the same UNORM grid),
//! `complementary` is complementary Z, `infinite` is infinite reversed-Z (n / w). Formats:
//! D16 UNORM, D24 UNORM (X8_D24 and D24_S8), float32 (D32 and D32_S8).

use glam::{DMat3, DQuat};
use revz_math::model::{
    min_separation_curve, Camera as ModelCamera, Mapping, Simulation, StorageFormat,
    VertexTransform,
};
use revz_math::VisibleRange;

use super::scenes::{stack_camera, STACK_NEAR};
use crate::target::DepthFormat;
use crate::variants::Variant;

/// Pairs per separation in the simulation.
const PAIRS: usize = 2000;

/// The model's mapping for a mode.
pub fn mapping(variant: Variant) -> Mapping {
    match variant {
        Variant::Complementary => Mapping::Complementary,
        Variant::Infinite => Mapping::InfiniteReversed,
        Variant::NoLayer | Variant::Off | Variant::Flip => Mapping::Standard,
    }
}

/// The model's storage format for a depth format.
pub fn storage(format: DepthFormat) -> StorageFormat {
    match format {
        DepthFormat::D16 => StorageFormat::D16,
        DepthFormat::X8D24 | DepthFormat::D24S8 => StorageFormat::D24,
        DepthFormat::D32 | DepthFormat::D32S8 => StorageFormat::D32F,
    }
}

/// The model's view of `plane-stack`'s camera at `aspect`.
fn simulation(variant: Variant, format: DepthFormat, aspect: f64) -> Simulation {
    let camera = stack_camera();
    let view_to_world = camera.view().inverse();
    let orientation = DQuat::from_mat3(&DMat3::from_mat4(view_to_world)).normalize();
    Simulation {
        camera: ModelCamera {
            position: camera.eye,
            orientation,
            vertical_fov: camera.fov_y,
            aspect_ratio: aspect,
        },
        range: VisibleRange::new(camera.near, camera.far).expect("0 < near < far"),
        mapping: mapping(variant),
        format: storage(format),
        transform: VertexTransform::Precomposed,
        pairs: PAIRS,
        seed: 1,
    }
}

/// The simulated minimum relative separation at each distance (in near-plane distances);
/// `None` where no separation below 1 resolves.
pub fn simulated(
    variant: Variant,
    format: DepthFormat,
    aspect: f64,
    distances_over_near: &[f64],
) -> Vec<Option<f64>> {
    let sim = simulation(variant, format, aspect);
    distances_over_near
        .iter()
        .map(|&d| sim.min_separation(d * STACK_NEAR).ok().flatten())
        .collect()
}

/// The storage-only minimum relative separation at each distance (in near-plane distances).
pub fn storage_only(
    variant: Variant,
    format: DepthFormat,
    distances_over_near: &[f64],
) -> Vec<Option<f64>> {
    let camera = stack_camera();
    let range = VisibleRange::new(camera.near, camera.far).expect("0 < near < far");
    let distances: Vec<f64> = distances_over_near.iter().map(|d| d * STACK_NEAR).collect();
    match min_separation_curve(mapping(variant), storage(format), range, &distances) {
        Ok(values) => values
            .into_iter()
            .map(|v| (v.is_finite() && v < 1.0).then_some(v))
            .collect(),
        Err(_) => vec![None; distances.len()],
    }
}
