//! Pure conversions between standard and reversed depth state (`shared/DESIGN.md` section 2).
//!
//! Every function here maps what the application asked for under standard depth (D) to what
//! the driver must get when the attachment holds reversed depth (1 - D). They are their own
//! inverses where the math allows, which the tests check.

use ash::vk;

/// The compare op that keeps the same visibility on reversed depth: LESS <-> GREATER,
/// LESS_OR_EQUAL <-> GREATER_OR_EQUAL; EQUAL, NOT_EQUAL, ALWAYS and NEVER are unchanged.
pub fn flip_compare_op(op: vk::CompareOp) -> vk::CompareOp {
    match op {
        vk::CompareOp::LESS => vk::CompareOp::GREATER,
        vk::CompareOp::GREATER => vk::CompareOp::LESS,
        vk::CompareOp::LESS_OR_EQUAL => vk::CompareOp::GREATER_OR_EQUAL,
        vk::CompareOp::GREATER_OR_EQUAL => vk::CompareOp::LESS_OR_EQUAL,
        other => other,
    }
}

/// A depth value on the reversed scale: d -> 1 - d. Computed in f64 so that values exactly
/// representable in the attachment (0, 1, k/2^n) map exactly.
pub fn flip_depth(depth: f32) -> f32 {
    (1.0 - f64::from(depth)) as f32
}

/// The flip path's viewport: depth range [a, b] -> [1 - a, 1 - b], so the rasterizer writes
/// 1 - D. (x, y, width, height are untouched.)
pub fn flip_viewport(viewport: vk::Viewport) -> vk::Viewport {
    vk::Viewport {
        min_depth: flip_depth(viewport.min_depth),
        max_depth: flip_depth(viewport.max_depth),
        ..viewport
    }
}

/// The precise path's viewport: depth range [a, b] -> [1 - b, 1 - a]. The rewritten projection
/// already produces reversed depth z' (1 - D, or n / w), and the application's range must still
/// be honoured: `(1 - b) + z' (b - a)` is `1 - (a + D (b - a))` for z' = 1 - D.
pub fn precise_viewport(viewport: vk::Viewport) -> vk::Viewport {
    vk::Viewport {
        min_depth: flip_depth(viewport.max_depth),
        max_depth: flip_depth(viewport.min_depth),
        ..viewport
    }
}

/// How a standard depth value maps onto a reversed attachment, for the state the projection
/// rewrite cannot reach (flip-path viewports, clear values, depth bounds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reversal {
    /// d -> 1 - d: the flip and complementary modes (complementary Z stores exactly 1 - D).
    Complementary,
    /// d -> 1 - (1 - r) d with r = n / f: infinite mode. A precise draw stores n / w, and for
    /// the standard D(w) = f (w - n) / (w (f - n)) of the same camera, n / w = 1 - (1 - n/f) D:
    /// an affine map, so flip-path draws, clears and bounds land on the same scale. r = 0 (an
    /// infinite far plane, or none seen yet) is the plain flip.
    Infinite { near_over_far: f32 },
}

impl Reversal {
    pub fn depth(self, depth: f32) -> f32 {
        match self {
            Reversal::Complementary => flip_depth(depth),
            Reversal::Infinite { near_over_far } => {
                (1.0 - (1.0 - f64::from(near_over_far)) * f64::from(depth)) as f32
            }
        }
    }

    /// The flip path's viewport: [a, b] -> [map(a), map(b)], so the rasterizer writes map(D).
    pub fn viewport(self, viewport: vk::Viewport) -> vk::Viewport {
        vk::Viewport {
            min_depth: self.depth(viewport.min_depth),
            max_depth: self.depth(viewport.max_depth),
            ..viewport
        }
    }

    /// Depth bounds [lo, hi] -> [map(hi), map(lo)].
    pub fn bounds(self, min: f32, max: f32) -> (f32, f32) {
        (self.depth(max), self.depth(min))
    }
}

/// Depth bias pushes toward the camera with negative values in standard depth; on reversed
/// depth the same push needs the opposite sign (constant, slope and clamp).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DepthBias {
    pub constant: f32,
    pub clamp: f32,
    pub slope: f32,
}

impl DepthBias {
    pub fn flipped(self) -> DepthBias {
        DepthBias {
            constant: -self.constant,
            clamp: -self.clamp,
            slope: -self.slope,
        }
    }
}

/// Depth bounds [lo, hi] -> [1 - hi, 1 - lo].
pub fn flip_depth_bounds(min: f32, max: f32) -> (f32, f32) {
    (flip_depth(max), flip_depth(min))
}

/// A depth resolve mode that picks the same sample on reversed depth: MIN <-> MAX.
pub fn flip_resolve_mode(mode: vk::ResolveModeFlags) -> vk::ResolveModeFlags {
    match mode {
        vk::ResolveModeFlags::MIN => vk::ResolveModeFlags::MAX,
        vk::ResolveModeFlags::MAX => vk::ResolveModeFlags::MIN,
        other => other,
    }
}

/// The depth aspect a format has, if any (depth-only or depth/stencil formats).
pub fn has_depth(format: vk::Format) -> bool {
    matches!(
        format,
        vk::Format::D16_UNORM
            | vk::Format::X8_D24_UNORM_PACK32
            | vk::Format::D32_SFLOAT
            | vk::Format::D16_UNORM_S8_UINT
            | vk::Format::D24_UNORM_S8_UINT
            | vk::Format::D32_SFLOAT_S8_UINT
    )
}

/// Whether a format has a stencil aspect (stencil-only or depth/stencil formats).
pub fn has_stencil(format: vk::Format) -> bool {
    matches!(
        format,
        vk::Format::S8_UINT
            | vk::Format::D16_UNORM_S8_UINT
            | vk::Format::D24_UNORM_S8_UINT
            | vk::Format::D32_SFLOAT_S8_UINT
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const OPS: [vk::CompareOp; 8] = [
        vk::CompareOp::NEVER,
        vk::CompareOp::LESS,
        vk::CompareOp::EQUAL,
        vk::CompareOp::LESS_OR_EQUAL,
        vk::CompareOp::GREATER,
        vk::CompareOp::NOT_EQUAL,
        vk::CompareOp::GREATER_OR_EQUAL,
        vk::CompareOp::ALWAYS,
    ];

    /// Whether `op` passes a fragment at `a` against the stored `b`.
    fn passes(op: vk::CompareOp, a: f64, b: f64) -> bool {
        match op {
            vk::CompareOp::NEVER => false,
            vk::CompareOp::LESS => a < b,
            vk::CompareOp::EQUAL => a == b,
            vk::CompareOp::LESS_OR_EQUAL => a <= b,
            vk::CompareOp::GREATER => a > b,
            vk::CompareOp::NOT_EQUAL => a != b,
            vk::CompareOp::GREATER_OR_EQUAL => a >= b,
            _ => true,
        }
    }

    #[test]
    fn flipped_compare_ops_decide_the_same_on_flipped_depths() {
        let depths = [0.0, 0.25, 0.5, 0.75, 1.0];
        for op in OPS {
            assert_eq!(flip_compare_op(flip_compare_op(op)), op);
            for a in depths {
                for b in depths {
                    assert_eq!(
                        passes(op, a, b),
                        passes(flip_compare_op(op), 1.0 - a, 1.0 - b),
                        "{op:?} {a} {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn depth_flips_are_exact_on_representable_values() {
        for d in [0.0f32, 1.0, 0.5, 0.25, 0.75, 0.125] {
            assert_eq!(flip_depth(flip_depth(d)), d);
        }
        assert_eq!(flip_depth(1.0), 0.0);
        let viewport = vk::Viewport {
            x: 1.0,
            y: 2.0,
            width: 3.0,
            height: 4.0,
            min_depth: 0.0,
            max_depth: 0.5,
        };
        let flipped = flip_viewport(viewport);
        assert_eq!((flipped.min_depth, flipped.max_depth), (1.0, 0.5));
        assert_eq!(
            (flipped.x, flipped.y, flipped.width, flipped.height),
            (1.0, 2.0, 3.0, 4.0)
        );
        assert_eq!(flip_depth_bounds(0.0, 0.75), (0.25, 1.0));
    }

    #[test]
    fn the_infinite_reversal_maps_standard_depth_to_near_over_w() {
        let (n, f) = (0.5f64, 200.0f64);
        let reversal = Reversal::Infinite {
            near_over_far: (n / f) as f32,
        };
        for w in [0.5, 1.0, 7.0, 150.0, 200.0] {
            let standard = f * (w - n) / (w * (f - n));
            let mapped = f64::from(reversal.depth(standard as f32));
            assert!(
                (mapped - n / w).abs() < 1e-6,
                "w = {w}: {mapped} vs {}",
                n / w
            );
        }
        assert_eq!(reversal.depth(0.0), 1.0);
        let plain = Reversal::Infinite { near_over_far: 0.0 };
        assert_eq!(plain.depth(0.25), Reversal::Complementary.depth(0.25));
        let viewport = vk::Viewport {
            min_depth: 0.0,
            max_depth: 1.0,
            ..Default::default()
        };
        let precise = precise_viewport(vk::Viewport {
            min_depth: 0.25,
            max_depth: 1.0,
            ..viewport
        });
        assert_eq!((precise.min_depth, precise.max_depth), (0.0, 0.75));
        let flip = Reversal::Complementary.viewport(viewport);
        assert_eq!((flip.min_depth, flip.max_depth), (1.0, 0.0));
    }

    #[test]
    fn stencil_aspects_are_those_of_stencil_and_depth_stencil_formats() {
        assert!(has_stencil(vk::Format::D32_SFLOAT_S8_UINT));
        assert!(has_stencil(vk::Format::S8_UINT));
        assert!(!has_stencil(vk::Format::D32_SFLOAT));
        assert!(!has_stencil(vk::Format::R8G8B8A8_UNORM));
    }

    #[test]
    fn bias_and_resolve_modes_flip() {
        let bias = DepthBias {
            constant: -2.0,
            clamp: -0.01,
            slope: -1.5,
        };
        assert_eq!(bias.flipped().flipped(), bias);
        assert_eq!(bias.flipped().constant, 2.0);
        assert_eq!(
            flip_resolve_mode(vk::ResolveModeFlags::MIN),
            vk::ResolveModeFlags::MAX
        );
        assert_eq!(
            flip_resolve_mode(vk::ResolveModeFlags::SAMPLE_ZERO),
            vk::ResolveModeFlags::SAMPLE_ZERO
        );
    }
}
