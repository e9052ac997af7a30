//! Reference depth in f64, depth as a GPU computes it in float32, and the bound between them
//! (the "float32 floor" of `DESIGN.md` section 3), for tests that compare the two.
//!
//! The bound of [`float32_depth_floor`] follows the error analysis of seed 001 (Upchurch &
//! Desbrun, section 2: every float32 operation has a relative error of at most u = 2^-24), in
//! the running form of a dot product: evaluating `sum a_i * v_i` left to right, each product
//! passes through at most 4 roundings, so the computed value is within `gamma_4 * sum |a_i v_i|`
//! of the exact one, `gamma_n = n u / (1 - n u)`. With
//!
//! - `a*` the exact (f64) depth row and `a = fl32(a*)` its once-rounded float32 copy,
//!   `|a_i - a*_i| <= u |a*_i|`,
//! - `c` the w row as the GPU has it (float32 values), `v` the float32 vertex position,
//! - `S_z = sum |a*_i v_i|`, `S_w = sum |c_i v_i|`, `w = c . v`, `D* = (a* . v) / w`,
//!
//! the GPU's `z` is within `e_z = (u + gamma_4 (1 + u)) S_z` of `a* . v`, its `w` within
//! `e_w = gamma_4 S_w` of `w`, and so
//!
//! ```text
//! |z_gpu / w_gpu - D*| <= X = (e_z + |D*| e_w) / (|w| - e_w)
//! |D_gpu - D*|         <= X + q * 2u * (|D*| + X)       (division correct to q ulps)
//! ```
//!
//! plus a term for the f64 evaluation of the reference (`4 * 2^-53 * (S_z + |D*| S_w) / |w|`)
//! and one for float32 underflow. The `u |D*|` part (rounding of the result) is "a few ulps";
//! `S_z / |w|` and `|D*| S_w / |w|` are the model-view rounding contribution. For the infinite
//! reversed row `a* = (0, 0, 0, n)`, `S_z = n` and the z term is exact: the depth is
//! `fl(n / w_gpu)`, within one ulp of n over the GPU's own w, however far the camera is from the
//! origin (seed 001: a = 0). Only w's own rounding remains, which moves x and y too.

use glam::{DMat4, DVec4, Mat4, Vec4};

/// Unit roundoff of float32, u = 2^-24: the largest relative error of one rounding.
pub const F32_UNIT_ROUNDOFF: f64 = 1.0 / 16_777_216.0;

/// Unit roundoff of f64, 2^-53.
const F64_UNIT_ROUNDOFF: f64 = f64::EPSILON / 2.0;

/// Smallest positive float32 (subnormal), the absolute error of an underflowing operation.
const F32_SMALLEST_SUBNORMAL: f64 = 1.401_298_464_324_817e-45;

/// `gamma_n = n u / (1 - n u)` for float32: the relative error bound of n roundings.
#[must_use]
pub fn float32_gamma(n: u32) -> f64 {
    let nu = f64::from(n) * F32_UNIT_ROUNDOFF;
    nu / (1.0 - nu)
}

/// Normalized depth `z_clip / w_clip` of `m * v`, in f64.
#[must_use]
pub fn reference_depth(m: &DMat4, v: DVec4) -> f64 {
    let clip = *m * v;
    clip.z / clip.w
}

/// `m * v` evaluated in float32 in the shader's order: column by column,
/// `((c0 * x + c1 * y) + c2 * z) + c3 * w`, a separate rounding for every multiply and add (no
/// fused multiply-add; Rust never contracts float operations).
#[must_use]
pub fn gpu_clip(m: &Mat4, v: Vec4) -> Vec4 {
    let columns = [m.x_axis, m.y_axis, m.z_axis, m.w_axis];
    let component = |row: usize| {
        let mut sum = columns[0][row] * v.x;
        sum += columns[1][row] * v.y;
        sum += columns[2][row] * v.z;
        sum += columns[3][row] * v.w;
        sum
    };
    Vec4::new(component(0), component(1), component(2), component(3))
}

/// Normalized depth of `m * v` as a GPU computes it: [`gpu_clip`], then one IEEE float32
/// division (correctly rounded; real GPUs may be up to 2.5 ulp off, see
/// [`float32_depth_floor`]'s `division_ulps`).
#[must_use]
pub fn gpu_depth(m: &Mat4, v: Vec4) -> f32 {
    let clip = gpu_clip(m, v);
    clip.z / clip.w
}

/// Upper bound on `|gpu_depth(fl32(M), v) - D*|` where `M` has the exact depth row
/// `exact_depth_row` (rounded once to float32 for the GPU) and the w row `w_row` (already
/// float32 values), `v` is float32-representable, and `D* = exact_depth_row . v / w_row . v`
/// (derivation in the module documentation). `division_ulps` is the accuracy of the GPU's
/// division: 0.5 for IEEE (what [`gpu_depth`] does), 2.5 for what Vulkan allows.
///
/// Returns `f64::INFINITY` when the w error bound reaches w itself (w's sign is not known).
#[must_use]
pub fn float32_depth_floor(
    exact_depth_row: DVec4,
    w_row: DVec4,
    v: DVec4,
    division_ulps: f64,
) -> f64 {
    let u = F32_UNIT_ROUNDOFF;
    let gamma_4 = float32_gamma(4);
    let sum_z = (exact_depth_row * v).abs().element_sum();
    let sum_w = (w_row * v).abs().element_sum();
    let w = w_row.dot(v);
    let depth = exact_depth_row.dot(v) / w;
    let underflow = 8.0 * F32_SMALLEST_SUBNORMAL;
    let error_z = (u + gamma_4 * (1.0 + u)) * sum_z + underflow;
    let error_w = gamma_4 * sum_w + underflow;
    if error_w >= w.abs() {
        return f64::INFINITY;
    }
    let quotient_error = (error_z + depth.abs() * error_w) / (w.abs() - error_w);
    let division_error = division_ulps * 2.0 * u * (depth.abs() + quotient_error);
    let reference_error = 4.0 * F64_UNIT_ROUNDOFF * (sum_z + depth.abs() * sum_w) / w.abs();
    quotient_error + division_error + reference_error
}

/// Size of one float32 ulp at `x` (the spacing of float32 values around `|x|`), in f64.
#[must_use]
pub fn float32_ulp(x: f64) -> f64 {
    let magnitude = (x.abs() as f32).max(f32::MIN_POSITIVE);
    f64::from(f32::from_bits(magnitude.to_bits() + 1) - magnitude)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_clip_matches_exact_arithmetic_on_exact_inputs() {
        let m = Mat4::from_cols_array(&std::array::from_fn(|i| i as f32 - 7.0));
        let v = Vec4::new(1.0, -2.0, 0.5, 1.0);
        let exact = m.as_dmat4() * v.as_dvec4();
        assert_eq!(gpu_clip(&m, v).as_dvec4(), exact);
    }

    #[test]
    fn infinite_reversed_depth_is_n_over_w_within_an_ulp() {
        let n = 0.1f32;
        let m = Mat4::from_cols(
            Vec4::new(1.0, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 1.0, 0.0, 0.0),
            Vec4::new(0.0, 0.0, 0.0, -1.0),
            Vec4::new(0.0, 0.0, n, 0.0),
        );
        let v = Vec4::new(3.0, 4.0, -12_345.679, 1.0);
        let depth = f64::from(gpu_depth(&m, v));
        let expected = f64::from(n) / 12_345.679f32 as f64;
        assert!((depth - expected).abs() <= float32_ulp(expected));
    }

    #[test]
    fn floor_covers_a_rounded_row() {
        let exact_row = DVec4::new(0.1, -0.2, 1.0 / 3.0, 0.7);
        let w_row = DVec4::new(0.0, 0.0, -1.0, 0.0);
        let m = DMat4::from_cols(DVec4::X, DVec4::Y, exact_row, w_row).transpose();
        let v = DVec4::new(0.3, 0.7, -2.5, 1.0);
        let gpu = f64::from(gpu_depth(&m.as_mat4(), v.as_vec4()));
        let reference = reference_depth(&m, v);
        let floor = float32_depth_floor(exact_row, w_row, v, 0.5);
        assert!((gpu - reference).abs() <= floor);
        assert!(floor < 1e-6);
    }

    #[test]
    fn ulp_sizes() {
        assert_eq!(float32_ulp(1.0), f64::from(f32::EPSILON));
        assert_eq!(float32_ulp(-1.5), f64::from(f32::EPSILON));
        assert_eq!(
            float32_ulp(0.0),
            f64::from(f32::MIN_POSITIVE) * f64::from(f32::EPSILON)
        );
    }

    #[test]
    fn floor_is_infinite_when_w_is_lost() {
        let floor = float32_depth_floor(
            DVec4::W,
            DVec4::new(1.0, 0.0, 0.0, -1.0),
            DVec4::new(1.0, 0.0, 0.0, 1.0),
            0.5,
        );
        assert_eq!(floor, f64::INFINITY);
    }
}
