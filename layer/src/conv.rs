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

    /// The precise path's viewport: depth range [a, b] -> [map(a) - (b - a), map(a)]. The
    /// rewritten projection already produces reversed depth z' = 1 - (1 - r) D (1 - D, or n / w
    /// in infinite mode), and the application's range must still be honoured on the map every
    /// other draw uses: `map(a) - (b - a) + z' (b - a)` is `map(a + D (b - a))`. For the full
    /// range that is [0, 1], z' itself; for the plain flip [1 - b, 1 - a]. (Before issue #21 infinite mode used [1 - b, 1 - a] too, which puts a range that does not
    /// start at 0 r a above the other draws: found by converting copies back.)
    ///
    /// A range inside [0, 1] (the only kind without `VK_EXT_depth_range_unrestricted`) keeps its
    /// image there: the rounding of `map(a) - (b - a)` just below 0 is clamped away. A range
    /// outside it (the application enabled the extension) goes down as computed, for the
    /// float depth image that holds such values.
    pub fn precise_viewport(self, viewport: vk::Viewport) -> vk::Viewport {
        let (a, b) = (f64::from(viewport.min_depth), f64::from(viewport.max_depth));
        let top = f64::from(self.depth(viewport.min_depth));
        let bottom = top - (b - a);
        let inside = (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b);
        vk::Viewport {
            min_depth: if inside {
                bottom.clamp(0.0, 1.0)
            } else {
                bottom
            } as f32,
            max_depth: top as f32,
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
    /// The representation the application gave with it (`VK_EXT_depth_bias_control`), which
    /// must go down with it again; `None`: the default (`vkCmdSetDepthBias`).
    pub representation: Option<BiasRepresentation>,
}

/// A `VkDepthBiasRepresentationInfoEXT`'s values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BiasRepresentation {
    pub representation: vk::DepthBiasRepresentationEXT,
    pub exact: bool,
}

impl BiasRepresentation {
    /// The representation of a chain's `VkDepthBiasRepresentationInfoEXT`.
    pub fn of(info: &vk::DepthBiasRepresentationInfoEXT<'_>) -> BiasRepresentation {
        BiasRepresentation {
            representation: info.depth_bias_representation,
            exact: info.depth_bias_exact == vk::TRUE,
        }
    }

    /// Whether the constant factor counts the format's least representable values (which
    /// promotion to float changes), as the default representation does.
    fn in_format_units(representation: Option<BiasRepresentation>) -> bool {
        representation.is_none_or(|r| {
            r.representation == vk::DepthBiasRepresentationEXT::LEAST_REPRESENTABLE_VALUE_FORMAT
        })
    }
}

impl DepthBias {
    /// The bias of an application written for a UNORM `format`, for its image promoted to
    /// float. The constant factor counts units `r` of the format (Vulkan spec, "Depth Bias"):
    /// 2^-16 (D16) or 2^-24 (D24) in UNORM, 2^(e - 23) in float, `e` the exponent of the
    /// primitive's largest depth. The factor is scaled by r_unorm / 2^-24, which is exact for
    /// depths in [0.5, 1] (standard depth beyond twice the near plane, reversed depth within
    /// it): there the float unit is 2^-24. At smaller depths the float unit halves with each
    /// octave, so the bias shrinks with the depth's own precision: a decal keeps the same
    /// number of representable steps over its surface, not the same distance. The slope
    /// factor and the clamp are in depth units in every format: unchanged.
    pub fn in_float_storage(self, format: vk::Format) -> DepthBias {
        // FLOAT and FORCE_UNORM representations name units that promotion does not change.
        if !BiasRepresentation::in_format_units(self.representation) {
            return self;
        }
        let Some(unit) = unorm_bias_unit(format) else {
            return self;
        };
        DepthBias {
            constant: self.constant * (unit / 2f32.powi(-24)),
            ..self
        }
    }

    /// The bias a draw into an attachment sends: in float units where the attachment is a
    /// promoted `promoted_from` image, negated where it is reversed.
    pub fn for_attachment(self, reversed: bool, promoted_from: Option<vk::Format>) -> DepthBias {
        let bias = match promoted_from {
            Some(format) => self.in_float_storage(format),
            None => self,
        };
        if reversed {
            bias.flipped()
        } else {
            bias
        }
    }

    pub fn flipped(self) -> DepthBias {
        DepthBias {
            constant: -self.constant,
            clamp: -self.clamp,
            slope: -self.slope,
            representation: self.representation,
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

/// The depth and stencil aspects a format has.
pub fn aspects_of(format: vk::Format) -> vk::ImageAspectFlags {
    let mut aspects = vk::ImageAspectFlags::empty();
    if has_depth(format) {
        aspects |= vk::ImageAspectFlags::DEPTH;
    }
    if has_stencil(format) {
        aspects |= vk::ImageAspectFlags::STENCIL;
    }
    aspects
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

/// The float depth format a UNORM depth format is promoted to (stencil kept): D16 and X8_D24
/// to D32_SFLOAT, D16_S8 and D24_S8 to D32_SFLOAT_S8_UINT. `None` for formats already float
/// or without depth.
pub fn float_depth_format(format: vk::Format) -> Option<vk::Format> {
    match format {
        vk::Format::D16_UNORM | vk::Format::X8_D24_UNORM_PACK32 => Some(vk::Format::D32_SFLOAT),
        vk::Format::D16_UNORM_S8_UINT | vk::Format::D24_UNORM_S8_UINT => {
            Some(vk::Format::D32_SFLOAT_S8_UINT)
        }
        _ => None,
    }
}

/// The bytes of one texel of a depth format's depth and stencil aspects as copies lay them out
/// (the driver's own storage may pad: D32_SFLOAT_S8_UINT is often 8): D16 2, X8_D24 4, D32 4,
/// plus 1 for stencil (D24_S8 4: the depth aspect copies as 4 bytes, stencil as 1, but they
/// are stored packed in 4). 0 for other formats.
pub fn depth_texel_bytes(format: vk::Format) -> u64 {
    match format {
        vk::Format::D16_UNORM => 2,
        vk::Format::X8_D24_UNORM_PACK32
        | vk::Format::D32_SFLOAT
        | vk::Format::D24_UNORM_S8_UINT => 4,
        vk::Format::D16_UNORM_S8_UINT => 3,
        vk::Format::D32_SFLOAT_S8_UINT => 5,
        _ => 0,
    }
}

/// The unit of a constant depth bias in a UNORM depth format: `r` of the Vulkan spec
/// ("Depth Bias"), 2^-16 for D16 and 2^-24 for D24 (the spec's minimum resolvable difference,
/// as drivers implement it). `None` for float and non-depth formats, whose `r` depends on the
/// primitive's depth.
pub fn unorm_bias_unit(format: vk::Format) -> Option<f32> {
    match format {
        vk::Format::D16_UNORM | vk::Format::D16_UNORM_S8_UINT => Some(2f32.powi(-16)),
        vk::Format::X8_D24_UNORM_PACK32 | vk::Format::D24_UNORM_S8_UINT => Some(2f32.powi(-24)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn promoted_bias_keeps_its_unit_where_float_and_unorm_units_agree() {
        let bias = DepthBias {
            constant: -8.0,
            clamp: -1e-4,
            slope: -12.0,
            representation: None,
        };
        // D24: 2^-24 is the float unit in [0.5, 1]: unchanged.
        assert_eq!(bias.in_float_storage(vk::Format::D24_UNORM_S8_UINT), bias);
        assert_eq!(bias.in_float_storage(vk::Format::X8_D24_UNORM_PACK32), bias);
        // D16: 2^-16 is 256 float units there.
        let d16 = bias.in_float_storage(vk::Format::D16_UNORM);
        assert_eq!(d16.constant, -8.0 * 256.0);
        assert_eq!((d16.slope, d16.clamp), (bias.slope, bias.clamp));
        // The absolute offset c * r agrees at depth 0.75 (float unit 2^-24).
        let float_unit = 0.75f32.to_bits();
        let next = f32::from_bits(float_unit + 1) - 0.75;
        assert_eq!(next, 2f32.powi(-24));
        assert_eq!(d16.constant * next, bias.constant * 2f32.powi(-16));
        // Float formats are left alone.
        assert_eq!(bias.in_float_storage(vk::Format::D32_SFLOAT), bias);
    }

    #[test]
    fn only_a_bias_in_the_formats_units_is_scaled_for_float_storage_and_flipping_keeps_its_representation(
    ) {
        let represented = |representation| DepthBias {
            constant: -8.0,
            clamp: 0.0,
            slope: -1.0,
            representation: Some(BiasRepresentation {
                representation,
                exact: true,
            }),
        };
        use vk::DepthBiasRepresentationEXT as R;
        for absolute in [R::FLOAT, R::LEAST_REPRESENTABLE_VALUE_FORCE_UNORM] {
            let bias = represented(absolute);
            assert_eq!(bias.in_float_storage(vk::Format::D16_UNORM), bias);
        }
        let in_format = represented(R::LEAST_REPRESENTABLE_VALUE_FORMAT);
        assert_eq!(
            in_format.in_float_storage(vk::Format::D16_UNORM).constant,
            -8.0 * 256.0
        );
        assert_eq!(
            in_format
                .for_attachment(true, Some(vk::Format::D16_UNORM))
                .constant,
            8.0 * 256.0
        );
        assert_eq!(in_format.for_attachment(false, None), in_format);
        let flipped = in_format.flipped();
        assert_eq!((flipped.constant, flipped.slope), (8.0, 1.0));
        assert_eq!(flipped.representation, in_format.representation);
    }

    #[test]
    fn unorm_formats_promote_to_float_keeping_stencil() {
        let cases = [
            (vk::Format::D16_UNORM, Some(vk::Format::D32_SFLOAT)),
            (
                vk::Format::X8_D24_UNORM_PACK32,
                Some(vk::Format::D32_SFLOAT),
            ),
            (
                vk::Format::D16_UNORM_S8_UINT,
                Some(vk::Format::D32_SFLOAT_S8_UINT),
            ),
            (
                vk::Format::D24_UNORM_S8_UINT,
                Some(vk::Format::D32_SFLOAT_S8_UINT),
            ),
            (vk::Format::D32_SFLOAT, None),
            (vk::Format::D32_SFLOAT_S8_UINT, None),
            (vk::Format::S8_UINT, None),
            (vk::Format::R8G8B8A8_UNORM, None),
        ];
        for (format, promoted) in cases {
            assert_eq!(float_depth_format(format), promoted, "{format:?}");
            if let Some(promoted) = promoted {
                assert_eq!(has_stencil(format), has_stencil(promoted), "{format:?}");
                assert!(depth_texel_bytes(promoted) >= depth_texel_bytes(format));
                assert!(unorm_bias_unit(format).is_some());
                assert!(unorm_bias_unit(promoted).is_none());
            }
        }
    }

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
        let quarter = vk::Viewport {
            min_depth: 0.25,
            max_depth: 1.0,
            ..viewport
        };
        let precise = Reversal::Complementary.precise_viewport(quarter);
        assert_eq!((precise.min_depth, precise.max_depth), (0.0, 0.75));
        // Infinite mode: z' = n / w = 1 - (1 - r) D through the precise viewport lands on the
        // map of a + D (b - a), the one flip-path draws and clears use.
        let r = 1e-3f32;
        let infinite = Reversal::Infinite { near_over_far: r };
        for range in [
            viewport,
            quarter,
            vk::Viewport {
                min_depth: 0.5,
                max_depth: 0.75,
                ..viewport
            },
            // VK_EXT_depth_range_unrestricted: ranges outside [0, 1] map as they are.
            vk::Viewport {
                min_depth: -0.5,
                max_depth: 1.5,
                ..viewport
            },
            vk::Viewport {
                min_depth: 2.0,
                max_depth: 0.25,
                ..viewport
            },
        ] {
            let precise = infinite.precise_viewport(range);
            let (a, b) = (f64::from(range.min_depth), f64::from(range.max_depth));
            for d in [0.0, 0.3, 1.0] {
                let z = 1.0 - (1.0 - f64::from(r)) * d;
                let (lo, hi) = (f64::from(precise.min_depth), f64::from(precise.max_depth));
                let stored = lo + z * (hi - lo);
                let expected = f64::from(infinite.depth((a + d * (b - a)) as f32));
                assert!(
                    (stored - expected).abs() < 1e-6,
                    "{range:?} {d}: {stored} vs {expected}"
                );
            }
        }
        let flip = Reversal::Complementary.viewport(viewport);
        assert_eq!((flip.min_depth, flip.max_depth), (1.0, 0.0));
        let unrestricted = vk::Viewport {
            min_depth: -0.5,
            max_depth: 1.5,
            ..viewport
        };
        let precise = Reversal::Complementary.precise_viewport(unrestricted);
        assert_eq!((precise.min_depth, precise.max_depth), (-0.5, 1.5));
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
            representation: None,
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
