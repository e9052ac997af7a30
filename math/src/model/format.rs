//! Depth storage formats: which values in [0, 1] a depth attachment can hold, how a depth is
//! rounded to one of them, and how far apart they are.
//!
//! Seed 000 (eq. 1) splits the eye-space error into the mapping's slope times the
//! representation error of D; this module is the second factor. It covers Vulkan's formats
//! (UNORM 16/24/32 and IEEE float32) and seed 000's generic small float of eq. (2), which
//! includes integer storage as the zero-exponent case, so that formats can be compared at one
//! bit budget as seed 000's figures do.

use super::ModelError;
use crate::precision::float32_ulp;

/// The largest float32 below 1, `1 - 2^-24`: depth never exceeds 1, so the float32 spacing at
/// 1 is the one below it.
const FLOAT32_BELOW_ONE: f64 = 1.0 - 1.0 / 16_777_216.0;

/// A depth storage format for values in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StorageFormat {
    /// Normalized unsigned integer (`D16_UNORM`, `X8_D24_UNORM_PACK32`, a 32-bit UNORM as
    /// seed 000's 32-bit integer buffer): `k / (2^bits - 1)`, rounded to nearest.
    Unorm(UnormFormat),
    /// IEEE float32 (`D32_SFLOAT`): 8-bit exponent, 23-bit mantissa, subnormals included,
    /// rounded to nearest even.
    Float32,
    /// Seed 000's unsigned small float (eq. 2), see [`SmallFloatFormat`].
    Float(SmallFloatFormat),
}

/// The bit count of a [`StorageFormat::Unorm`], 1 to 32.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct UnormFormat {
    bits: u32,
}

impl UnormFormat {
    /// A UNORM format of `bits` bits.
    ///
    /// # Errors
    ///
    /// [`ModelError::InvalidFormat`] unless `1 <= bits <= 32`.
    pub fn new(bits: u32) -> Result<Self, ModelError> {
        if (1..=32).contains(&bits) {
            Ok(Self { bits })
        } else {
            Err(ModelError::InvalidFormat)
        }
    }

    /// The number of bits.
    #[must_use]
    pub fn bits(self) -> u32 {
        self.bits
    }

    /// `2^bits - 1`, the stored integer of D = 1.
    fn levels(self) -> f64 {
        2f64.powi(self.bits as i32) - 1.0
    }
}

/// Seed 000's floating-point storage (eq. 2) with `n` exponent bits and `m` mantissa bits, no
/// sign (all depths are >= 0; seed 000: "sign bit, if present, doesn't affect precision"):
///
/// ```text
/// e > 0 (normal):     2^(e - 2^n) * 1.f         0 < e < 2^n
/// e = 0 (subnormal):  2^(1 - 2^n) * 0.f
/// ```
///
/// The exponent bias is `2^n`, not IEEE's `2^(n-1) - 1`: the largest exponent is used for
/// `[1/2, 1)` and nothing is spent on values above 1 or on infinities, so the whole code space
/// covers [0, 1). `n = 0` is m-bit integer storage (only `e = 0`: `0.f`, spacing `2^-m`), and
/// `n = 1` is the same grid with one more bit, as seed 000 notes. Subnormals are kept (the
/// `e = 0` line of eq. 2), so the spacing below `2^(1 - 2^n)` is uniform, `2^(1 - 2^n - m)`.
///
/// The one corner seed 000 leaves to the implementation: 1 itself is not in eq. (2) (the
/// largest value is `1 - 2^-(m+1)`); here 1 is treated as stored exactly, as in UNORM formats,
/// so the cleared far plane of a standard buffer is representable. It changes nothing but the
/// last half step below 1.
///
/// `n <= 8` and `m <= 40` keep every value and spacing exact in f64.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SmallFloatFormat {
    exponent_bits: u32,
    mantissa_bits: u32,
}

impl SmallFloatFormat {
    /// A small float with `exponent_bits` (0 to 8) and `mantissa_bits` (0 to 40), at least
    /// one bit in all.
    ///
    /// # Errors
    ///
    /// [`ModelError::InvalidFormat`] outside those bounds.
    pub fn new(exponent_bits: u32, mantissa_bits: u32) -> Result<Self, ModelError> {
        if exponent_bits <= 8 && mantissa_bits <= 40 && exponent_bits + mantissa_bits >= 1 {
            Ok(Self {
                exponent_bits,
                mantissa_bits,
            })
        } else {
            Err(ModelError::InvalidFormat)
        }
    }

    /// Exponent bits (`n` of eq. 2).
    #[must_use]
    pub fn exponent_bits(self) -> u32 {
        self.exponent_bits
    }

    /// Mantissa bits (`m` of eq. 2).
    #[must_use]
    pub fn mantissa_bits(self) -> u32 {
        self.mantissa_bits
    }

    /// The exponent of the smallest normal binade, `1 - 2^n` (its values are
    /// `2^(1 - 2^n) * 1.f`); for integer storage (n = 0) everything is "subnormal".
    fn smallest_normal_exponent(self) -> i32 {
        1 - (1i32 << self.exponent_bits)
    }

    /// Spacing of the grid on the binade containing `d` in [0, 1].
    fn step_at(self, d: f64) -> f64 {
        let mantissa = self.mantissa_bits as i32;
        if self.exponent_bits == 0 {
            return 2f64.powi(-mantissa);
        }
        let smallest = self.smallest_normal_exponent();
        // The binade [2^e, 2^(e+1)) of d, at most [1/2, 1) (1 belongs to the last binade).
        let exponent = binade(d).clamp(smallest, -1);
        2f64.powi(exponent - mantissa)
    }
}

/// `floor(log2(d))` for a positive finite `d`, exact (`log2` alone may be off by one next to
/// a power of two); `i32::MIN` for 0 or below.
fn binade(d: f64) -> i32 {
    if d <= 0.0 || d.is_nan() {
        return i32::MIN;
    }
    let mut exponent = d.log2().floor() as i32;
    while 2f64.powi(exponent) > d {
        exponent -= 1;
    }
    while 2f64.powi(exponent + 1) <= d {
        exponent += 1;
    }
    exponent
}

impl StorageFormat {
    /// `D16_UNORM`.
    pub const D16: Self = Self::Unorm(UnormFormat { bits: 16 });
    /// `X8_D24_UNORM_PACK32` / `D24_UNORM_S8_UINT`.
    pub const D24: Self = Self::Unorm(UnormFormat { bits: 24 });
    /// A 32-bit UNORM buffer (seed 000's 32-bit integer W buffer; no Vulkan format).
    pub const D32: Self = Self::Unorm(UnormFormat { bits: 32 });
    /// `D32_SFLOAT`.
    pub const D32F: Self = Self::Float32;

    /// A UNORM format of `bits` bits.
    ///
    /// # Errors
    ///
    /// As [`UnormFormat::new`].
    pub fn unorm(bits: u32) -> Result<Self, ModelError> {
        UnormFormat::new(bits).map(Self::Unorm)
    }

    /// Seed 000's small float with `exponent_bits` and `mantissa_bits`.
    ///
    /// # Errors
    ///
    /// As [`SmallFloatFormat::new`].
    pub fn float(exponent_bits: u32, mantissa_bits: u32) -> Result<Self, ModelError> {
        SmallFloatFormat::new(exponent_bits, mantissa_bits).map(Self::Float)
    }

    /// Bits per stored depth (float32 counts its unused sign bit, as a `D32_SFLOAT` pixel
    /// does).
    #[must_use]
    pub fn bits(self) -> u32 {
        match self {
            Self::Unorm(unorm) => unorm.bits,
            Self::Float32 => 32,
            Self::Float(small) => small.exponent_bits + small.mantissa_bits,
        }
    }

    /// The stored value of depth `d`: clamped to [0, 1] (NaN stores 0), then rounded to the
    /// nearest representable value, ties to even.
    #[must_use]
    pub fn quantize(self, d: f64) -> f64 {
        let d = if d.is_nan() { 0.0 } else { d.clamp(0.0, 1.0) };
        match self {
            Self::Unorm(unorm) => {
                let levels = unorm.levels();
                (d * levels).round_ties_even() / levels
            }
            // `as` rounds to the nearest float32, ties to even, subnormals included.
            Self::Float32 => f64::from(d as f32),
            Self::Float(small) => {
                // Rounding on the grid of d's binade is exact rounding: a value that rounds up
                // to the next power of two lands on it, which both binades share.
                let step = small.step_at(d);
                ((d / step).round_ties_even() * step).min(1.0)
            }
        }
    }

    /// Spacing of the representable values around `d` in [0, 1]: the step of the binade
    /// containing `d` for floats (the step above a power of two; at 1, the step below it),
    /// the constant step for UNORM.
    #[must_use]
    pub fn step_at(self, d: f64) -> f64 {
        let d = if d.is_nan() { 0.0 } else { d.clamp(0.0, 1.0) };
        match self {
            Self::Unorm(unorm) => 1.0 / unorm.levels(),
            Self::Float32 => float32_ulp(d.min(FLOAT32_BELOW_ONE)),
            Self::Float(small) => small.step_at(d),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(e: u32, m: u32) -> StorageFormat {
        StorageFormat::float(e, m).expect("valid format")
    }

    #[test]
    fn unorm_grid() {
        let d16 = StorageFormat::D16;
        assert_eq!(d16.step_at(0.3), 1.0 / 65535.0);
        assert_eq!(d16.quantize(1.0), 1.0);
        assert_eq!(d16.quantize(0.6 / 65535.0), 1.0 / 65535.0);
        assert_eq!(d16.quantize(-3.0), 0.0);
        assert_eq!(StorageFormat::D24.quantize(0.5), 8_388_608.0 / 16_777_215.0);
        assert!(StorageFormat::unorm(0).is_err());
        assert!(StorageFormat::unorm(33).is_err());
    }

    #[test]
    fn float32_grid() {
        let d32f = StorageFormat::D32F;
        assert_eq!(d32f.step_at(1.0), 2f64.powi(-24));
        assert_eq!(d32f.step_at(0.75), 2f64.powi(-24));
        assert_eq!(d32f.step_at(0.25), 2f64.powi(-25));
        assert_eq!(d32f.step_at(0.0), 2f64.powi(-149));
        assert_eq!(d32f.quantize(1e-45), 2f64.powi(-149));
        assert_eq!(d32f.quantize(0.1), f64::from(0.1f32));
    }

    #[test]
    fn small_float_follows_equation_2() {
        // 4 exponent bits, 12 mantissa bits (seed 000's 16-bit float): bias 16, normal
        // binades [2^-15, 2^-14) .. [1/2, 1), subnormals below 2^-15 with spacing 2^-27.
        let f16 = small(4, 12);
        assert_eq!(f16.step_at(0.75), 2f64.powi(-13));
        assert_eq!(f16.step_at(0.5), 2f64.powi(-13));
        assert_eq!(f16.step_at(0.4999), 2f64.powi(-14));
        assert_eq!(f16.step_at(2f64.powi(-15)), 2f64.powi(-27));
        assert_eq!(f16.step_at(1e-9), 2f64.powi(-27));
        assert_eq!(f16.step_at(0.0), 2f64.powi(-27));
        assert_eq!(f16.quantize(1.0), 1.0);
        assert_eq!(f16.quantize(0.5 - 2f64.powi(-16)), 0.5);
        assert_eq!(f16.bits(), 16);
    }

    #[test]
    fn zero_and_one_exponent_bits_are_integers() {
        let integer = small(0, 16);
        let one_bit = small(1, 15);
        for d in [0.0, 0.1, 0.4999, 0.5, 0.77, 1.0] {
            assert_eq!(integer.step_at(d), 2f64.powi(-16), "at {d}");
            assert_eq!(one_bit.step_at(d), 2f64.powi(-16), "at {d}");
            assert_eq!(integer.quantize(d), one_bit.quantize(d), "at {d}");
        }
        assert!(StorageFormat::float(9, 10).is_err());
        assert!(StorageFormat::float(0, 0).is_err());
    }

    #[test]
    fn eight_bit_exponent_matches_float32_above_its_subnormals() {
        let like_float32 = small(8, 23);
        for d in [1e-30, 3.3e-7, 0.1, 0.3, 0.6, 0.999_999] {
            assert_eq!(
                like_float32.step_at(d),
                StorageFormat::D32F.step_at(d),
                "at {d}"
            );
            assert_eq!(
                like_float32.quantize(d),
                StorageFormat::D32F.quantize(d),
                "at {d}"
            );
        }
    }

    #[test]
    fn binade_is_exact_at_powers_of_two() {
        for exponent in -60..0 {
            let power = 2f64.powi(exponent);
            assert_eq!(binade(power), exponent);
            assert_eq!(binade(power * (1.0 - f64::EPSILON)), exponent - 1);
        }
        assert_eq!(binade(0.0), i32::MIN);
    }
}
