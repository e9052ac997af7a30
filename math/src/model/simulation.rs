//! Float32 simulation of the vertex path: how close two surfaces can be before the GPU sorts
//! them wrongly, counting every rounding between the application's f64 camera and the stored
//! depth, not only the storage step.
//!
//! This is the measurement behind `DESIGN.md` section 3. The storage-only model
//! ([`super::separation`]) misses what seed 001 (Upchurch & Desbrun) is about: the projection
//! matrix is rounded to float32 once (a precomposed `P*V` even folds the view matrix's
//! rounding into the depth row), the shader's dot products and the perspective division
//! round again, and only then is the depth quantized. Those errors differ between the two
//! surfaces, so they can swap the order even when the format would tell them apart.
//!
//! One experiment, for a mapping a projection matrix can produce (standard, complementary,
//! infinite reversed; [`Mapping::projection_coefficients`]):
//!
//! 1. The camera's view matrix `V` (any position and rotation, in f64) and projection `P`
//!    (depth row `k * r3 + B * e3` from the exact (k, B) of the range) are built in f64.
//! 2. `pairs` view rays are drawn uniformly over the screen, each with a view depth drawn
//!    uniformly in `[z, z (1 + DISTANCE_JITTER)]` (a spread over a tenth of the distance, so
//!    that the pairs sample every position within a storage step rather than one). The
//!    nearer surface is at that depth on the ray, the farther one at `(1 + s)` times it on the
//!    same ray (the same pixel). Both are turned into world positions in f64 and rounded to
//!    float32: the vertex buffer.
//! 3. Each point goes through the shader's float32 arithmetic ([`gpu_clip`], seed 001's
//!    model: every multiply and add rounded, no FMA): either precomposed, `fl32(P*V) * p`
//!    (`P*V` multiplied in f64 and rounded once, what an application pushes), or two-step,
//!    `fl32(P) * (fl32(V) * p)` (seed 001, section 4.1). Clipping (`0 <= z <= w`) is applied
//!    in float32, the division `z / w` is one IEEE float32 division, and the result is
//!    quantized by the storage format.
//! 4. The pair sorts correctly when the nearer surface strictly wins: it passes the depth test
//!    against the cleared value (1 for LESS, 0 for GREATER) and against the farther one's
//!    stored value, which it must beat strictly because the farther one may have been drawn
//!    first. A farther surface that was clipped away cannot win.
//!
//! [`Simulation::min_separation`] scans `s` over [`separation_grid`] (10 values per decade
//! from 1e-8 to 1) from below and reports the first `s` at which fewer than 1% of the pairs
//! sort wrongly. The pairs are the same for every `s` (common random numbers, from a seeded
//! SplitMix64), so the fraction falls almost monotonically and the result is deterministic.
//! Separations that would put a farther surface beyond a clipping far plane are not tried
//! (they would be "resolved" by clipping, not by depth): for the finite mappings the scan
//! stops at `f / (z (1 + DISTANCE_JITTER)) - 1`.

use glam::{DMat4, DQuat, DVec3, DVec4, Mat4, Vec4};

use super::format::StorageFormat;
use super::mapping::Mapping;
use super::ModelError;
use crate::matrix::{from_rows, E3};
use crate::precision::gpu_clip;
use crate::range::VisibleRange;

/// Fraction of the pairs at or above which a separation counts as not resolved.
pub const WRONG_ORDER_LIMIT: f64 = 0.01;

/// Relative spread of the nearer surface's view depth above the requested distance.
pub const DISTANCE_JITTER: f64 = 0.1;

/// Grid points per decade of [`separation_grid`].
const GRID_PER_DECADE: i32 = 10;

/// Decades of [`separation_grid`] below 1.
const GRID_DECADES: i32 = 8;

/// The relative separations the simulation tries, from 1e-8 to 1 with 10 values per decade
/// (81 values, increasing).
pub fn separation_grid() -> impl Iterator<Item = f64> {
    let last = GRID_PER_DECADE * GRID_DECADES;
    (0..=last).map(move |index| 10f64.powf(f64::from(index - last) / f64::from(GRID_PER_DECADE)))
}

/// A perspective camera: where it is, where it looks, how wide it sees.
///
/// View space is right-handed with the camera looking down `-z` (glam's `rh` and seed 002's
/// convention), so the view depth is `w = -z_view`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Camera position in world space.
    pub position: DVec3,
    /// Rotation from view space to world space (unit quaternion).
    pub orientation: DQuat,
    /// Vertical field of view in radians, in (0, pi).
    pub vertical_fov: f64,
    /// Width over height of the screen, > 0.
    pub aspect_ratio: f64,
}

impl Default for Camera {
    /// At the origin, looking down `-z`, 60 degrees vertical field of view, 16:9.
    fn default() -> Self {
        Self {
            position: DVec3::ZERO,
            orientation: DQuat::IDENTITY,
            vertical_fov: std::f64::consts::FRAC_PI_3,
            aspect_ratio: 16.0 / 9.0,
        }
    }
}

impl Camera {
    fn validate(&self) -> Result<(), ModelError> {
        let valid = self.position.is_finite()
            && self.orientation.is_finite()
            && (self.orientation.length() - 1.0).abs() < 1e-9
            && self.vertical_fov > 0.0
            && self.vertical_fov < std::f64::consts::PI
            && self.aspect_ratio.is_finite()
            && self.aspect_ratio > 0.0;
        if valid {
            Ok(())
        } else {
            Err(ModelError::InvalidCamera)
        }
    }

    /// View space to world space, in f64.
    #[must_use]
    pub fn view_to_world(&self) -> DMat4 {
        DMat4::from_rotation_translation(self.orientation, self.position)
    }

    /// The view matrix `V` (world space to view space), in f64.
    #[must_use]
    pub fn view_matrix(&self) -> DMat4 {
        let inverse = self.orientation.inverse();
        DMat4::from_rotation_translation(inverse, -(inverse * self.position))
    }

    /// The Vulkan projection `P` of `mapping` over `range` in f64, or `None` for a mapping no
    /// projection matrix produces. The w row is `(0, 0, -1, 0)` (w = view depth) and the depth
    /// row `k * r3 + B * e3` with the exact (k, B) of [`Mapping::projection_coefficients`].
    #[must_use]
    pub fn projection(&self, mapping: Mapping, range: VisibleRange) -> Option<DMat4> {
        let line = mapping.projection_coefficients(range)?;
        let focal = 1.0 / (0.5 * self.vertical_fov).tan();
        let w_row = DVec4::new(0.0, 0.0, -1.0, 0.0);
        Some(from_rows([
            DVec4::new(focal / self.aspect_ratio, 0.0, 0.0, 0.0),
            DVec4::new(0.0, focal, 0.0, 0.0),
            line.k * w_row + line.b * E3,
            w_row,
        ]))
    }
}

/// How the vertex shader applies the camera (seed 001, section 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VertexTransform {
    /// `fl32(P*V) * p`: one matrix, precomposed in f64 and rounded once.
    Precomposed,
    /// `fl32(P) * (fl32(V) * p)`: to view space first, then the projection.
    TwoStep,
}

/// One float32 simulation setup (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Simulation {
    /// The camera.
    pub camera: Camera,
    /// Near and far planes of the projection.
    pub range: VisibleRange,
    /// The depth mapping the projection produces: standard, complementary or infinite
    /// reversed.
    pub mapping: Mapping,
    /// The depth attachment's format.
    pub format: StorageFormat,
    /// How the shader applies the camera.
    pub transform: VertexTransform,
    /// Surface pairs per tried separation (a few thousand give the 1% threshold to about
    /// one grid step).
    pub pairs: usize,
    /// Seed of the pseudo-random rays and depths.
    pub seed: u64,
}

impl Simulation {
    /// The fraction of pairs at view depth about `distance` (see [`DISTANCE_JITTER`]) and
    /// relative separation `separation` that sort wrongly.
    ///
    /// # Errors
    ///
    /// As [`Simulation::min_separation`], and [`ModelError::InvalidSeparation`] for a
    /// `separation` that is not finite and positive.
    pub fn wrong_order_fraction(&self, distance: f64, separation: f64) -> Result<f64, ModelError> {
        if !(separation.is_finite() && separation > 0.0) {
            return Err(ModelError::InvalidSeparation(separation));
        }
        let experiment = Experiment::new(self, distance)?;
        let wrong = experiment.wrong_pairs(separation, usize::MAX);
        Ok(wrong as f64 / self.pairs as f64)
    }

    /// The smallest relative separation `dz / z` on [`separation_grid`] at which fewer than
    /// 1% of the pairs at view depth about `distance` sort wrongly, or `None` when no tried
    /// separation gets there (the "-" of `DESIGN.md` section 3).
    ///
    /// # Errors
    ///
    /// [`ModelError::InvalidCamera`], [`ModelError::NotAProjection`] for a mapping no
    /// projection matrix produces, [`ModelError::TooFewSamples`] for no pairs, and
    /// [`ModelError::DistanceOutsideRange`] unless
    /// `n <= distance` and `distance * (1 + DISTANCE_JITTER) <= f`.
    pub fn min_separation(&self, distance: f64) -> Result<Option<f64>, ModelError> {
        let experiment = Experiment::new(self, distance)?;
        // Fewer than 1% wrong: `wrong < budget` with budget = ceil(pairs / 100).
        let budget = self.pairs.div_ceil(100);
        let largest = experiment.largest_separation();
        Ok(separation_grid()
            .take_while(|&separation| separation <= largest)
            .find(|&separation| experiment.wrong_pairs(separation, budget) < budget))
    }
}

/// [`Simulation::min_separation`] of `simulation` at `distance`.
///
/// # Errors
///
/// As [`Simulation::min_separation`].
pub fn simulated_min_separation(
    simulation: &Simulation,
    distance: f64,
) -> Result<Option<f64>, ModelError> {
    simulation.min_separation(distance)
}

/// [`Simulation::min_separation`] at every distance in `distances` (relative separations,
/// `None` where nothing up to 1 resolves), for plotting next to
/// [`super::min_separation_curve`].
///
/// # Errors
///
/// As [`Simulation::min_separation`], for the first distance that fails.
pub fn simulated_min_separation_curve(
    simulation: &Simulation,
    distances: &[f64],
) -> Result<Vec<Option<f64>>, ModelError> {
    distances
        .iter()
        .map(|&distance| simulation.min_separation(distance))
        .collect()
}

/// The float32 matrices the GPU gets.
#[derive(Debug)]
struct Pipeline {
    transform: VertexTransform,
    /// `fl32(P*V)`.
    precomposed: Mat4,
    /// `fl32(V)`.
    view: Mat4,
    /// `fl32(P)`.
    projection: Mat4,
    format: StorageFormat,
    reversed: bool,
}

impl Pipeline {
    /// The stored depth of world position `p`, or `None` when the primitive is clipped.
    fn stored(&self, p: Vec4) -> Option<f64> {
        let clip = match self.transform {
            VertexTransform::Precomposed => gpu_clip(&self.precomposed, p),
            VertexTransform::TwoStep => gpu_clip(&self.projection, gpu_clip(&self.view, p)),
        };
        let inside = clip.w > 0.0 && clip.z >= 0.0 && clip.z <= clip.w;
        inside.then(|| self.format.quantize(f64::from(clip.z / clip.w)))
    }

    /// Whether a fragment of stored depth `a` passes the depth test against `b`.
    fn passes(&self, a: f64, b: f64) -> bool {
        if self.reversed {
            a > b
        } else {
            a < b
        }
    }

    /// Whether the nearer surface is what the pixel ends up showing, whichever was drawn
    /// first.
    fn nearer_wins(&self, nearer: Option<f64>, farther: Option<f64>) -> bool {
        let clear = if self.reversed { 0.0 } else { 1.0 };
        nearer.is_some_and(|near| {
            self.passes(near, clear) && farther.is_none_or(|far| self.passes(near, far))
        })
    }
}

/// The pairs of one distance, with the nearer surfaces' stored depths computed once.
#[derive(Debug)]
struct Experiment {
    pipeline: Pipeline,
    view_to_world: DMat4,
    /// Nearer surfaces in view space (f64, before rounding to the vertex buffer).
    nearer: Vec<DVec3>,
    nearer_stored: Vec<Option<f64>>,
    /// The largest separation that keeps every farther surface inside a clipping far plane.
    largest_separation: f64,
}

impl Experiment {
    fn new(simulation: &Simulation, distance: f64) -> Result<Self, ModelError> {
        let Simulation {
            camera,
            range,
            mapping,
            format,
            transform,
            pairs,
            seed,
        } = *simulation;
        camera.validate()?;
        if pairs == 0 {
            return Err(ModelError::TooFewSamples);
        }
        let projection = camera
            .projection(mapping, range)
            .ok_or(ModelError::NotAProjection(mapping))?;
        let farthest_nearer = distance * (1.0 + DISTANCE_JITTER);
        if !(distance.is_finite() && distance >= range.near() && farthest_nearer <= range.far()) {
            return Err(ModelError::DistanceOutsideRange(distance));
        }
        let view = camera.view_matrix();
        let pipeline = Pipeline {
            transform,
            precomposed: (projection * view).as_mat4(),
            view: view.as_mat4(),
            projection: projection.as_mat4(),
            format,
            reversed: mapping.is_reversed(),
        };
        let view_to_world = camera.view_to_world();
        let half_height = (0.5 * camera.vertical_fov).tan();
        let half_width = half_height * camera.aspect_ratio;
        let mut random = SplitMix64::new(seed);
        let nearer: Vec<DVec3> = (0..pairs)
            .map(|_| {
                let x = (2.0 * random.next_f64() - 1.0) * half_width;
                let y = (2.0 * random.next_f64() - 1.0) * half_height;
                let depth = distance * (1.0 + DISTANCE_JITTER * random.next_f64());
                DVec3::new(x, y, -1.0) * depth
            })
            .collect();
        let nearer_stored = nearer
            .iter()
            .map(|&point| pipeline.stored(vertex(&view_to_world, point)))
            .collect();
        // Infinite reversed has no far clipping; the others clip at f.
        let largest_separation = if mapping == Mapping::InfiniteReversed {
            f64::INFINITY
        } else {
            range.far() / farthest_nearer - 1.0
        };
        Ok(Self {
            pipeline,
            view_to_world,
            nearer,
            nearer_stored,
            largest_separation,
        })
    }

    fn largest_separation(&self) -> f64 {
        self.largest_separation
    }

    /// The number of pairs at relative separation `separation` that sort wrongly, counted up
    /// to `budget` (the count stops there: enough to know the separation fails).
    fn wrong_pairs(&self, separation: f64, budget: usize) -> usize {
        let mut wrong = 0;
        for (&point, &nearer) in self.nearer.iter().zip(&self.nearer_stored) {
            let farther = self
                .pipeline
                .stored(vertex(&self.view_to_world, point * (1.0 + separation)));
            if !self.pipeline.nearer_wins(nearer, farther) {
                wrong += 1;
                if wrong >= budget {
                    break;
                }
            }
        }
        wrong
    }
}

/// The vertex-buffer position of a view-space point: world position in f64, rounded to
/// float32.
fn vertex(view_to_world: &DMat4, view_point: DVec3) -> Vec4 {
    view_to_world
        .transform_point3(view_point)
        .as_vec3()
        .extend(1.0)
}

/// SplitMix64 (Steele, Lea & Flood 2014, the seeding generator of `java.util.SplittableRandom`
/// and xoshiro): tiny, deterministic on every platform, plenty for sampling rays.
#[derive(Debug, Clone)]
struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1), 53 random bits.
    fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_has_ten_values_per_decade() {
        let grid: Vec<f64> = separation_grid().collect();
        assert_eq!(grid.len(), 81);
        assert!((grid[0] - 1e-8).abs() < 1e-22);
        assert_eq!(grid[80], 1.0);
        assert!((grid[10] - 1e-7).abs() < 1e-21);
        assert!(grid.windows(2).all(|pair| pair[0] < pair[1]));
    }

    #[test]
    fn splitmix_reference_values() {
        // First outputs for seed 0 (the published reference sequence).
        let mut random = SplitMix64::new(0);
        assert_eq!(random.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(random.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        let mut unit = SplitMix64::new(7);
        assert!((0..1000).all(|_| (0.0..1.0).contains(&unit.next_f64())));
    }

    #[test]
    fn view_matrix_inverts_the_pose() {
        let camera = Camera {
            position: DVec3::new(10.0, -3.0, 7.0),
            orientation: DQuat::from_euler(glam::EulerRot::YXZ, 0.3, -0.2, 0.1),
            ..Camera::default()
        };
        let identity = camera.view_matrix() * camera.view_to_world();
        assert!(identity.abs_diff_eq(DMat4::IDENTITY, 1e-12));
    }

    #[test]
    fn projection_puts_the_planes_at_zero_and_one() {
        let range = VisibleRange::new(0.5, 50.0).expect("valid range");
        let camera = Camera::default();
        let standard = camera
            .projection(Mapping::Standard, range)
            .expect("a projection");
        let at = |m: &DMat4, w: f64| {
            let clip = *m * DVec4::new(0.0, 0.0, -w, 1.0);
            (clip.z / clip.w, clip.w)
        };
        assert_eq!(at(&standard, 0.5), (0.0, 0.5));
        assert!((at(&standard, 50.0).0 - 1.0).abs() < 1e-15);
        let reversed = camera
            .projection(Mapping::Complementary, range)
            .expect("a projection");
        assert!((at(&reversed, 0.5).0 - 1.0).abs() < 1e-15);
        assert!(camera.projection(Mapping::W, range).is_none());
    }

    #[test]
    fn invalid_inputs_are_errors() {
        let simulation = Simulation {
            camera: Camera::default(),
            range: VisibleRange::new(0.1, 100.0).expect("valid range"),
            mapping: Mapping::Complementary,
            format: StorageFormat::D32F,
            transform: VertexTransform::Precomposed,
            pairs: 10,
            seed: 1,
        };
        assert_eq!(
            simulation.min_separation(95.0),
            Err(ModelError::DistanceOutsideRange(95.0))
        );
        assert_eq!(
            Simulation {
                mapping: Mapping::W,
                ..simulation
            }
            .min_separation(1.0),
            Err(ModelError::NotAProjection(Mapping::W))
        );
        assert_eq!(
            Simulation {
                pairs: 0,
                ..simulation
            }
            .min_separation(1.0),
            Err(ModelError::TooFewSamples)
        );
        let mut bad_camera = simulation;
        bad_camera.camera.vertical_fov = 0.0;
        assert_eq!(
            bad_camera.min_separation(1.0),
            Err(ModelError::InvalidCamera)
        );
        assert_eq!(
            simulation.wrong_order_fraction(1.0, -1.0),
            Err(ModelError::InvalidSeparation(-1.0))
        );
    }
}
