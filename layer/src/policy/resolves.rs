//! Multisample depth resolves out of reversed attachments: whether a resolve's source must
//! become native ([`DepthResolve::demotes_source`]), which MIN/MAX mode a reversed resolve
//! uses on the device ([`ResolveSupport::swapped_depth_mode`]; for a rendering instance,
//! [`ResolveSupport::reversed_resolve`]), and whether a render pass gets a twin with its
//! MIN/MAX resolve swapped ([`ResolveSupport::twin_resolve`]); what a resolve makes of its
//! destination ([`resolved_destination`]) and which end of a resolve pair follows a demotion
//! ([`follows_demotion`]); and what revz reads of a device's resolve support
//! ([`ResolveSupport::queried`], [`ResolveSupport::reported`]).

use ash::vk;

use super::NativeReason;
use crate::command_state::Target;
use crate::conv::flip_resolve_mode;

/// A multisample depth resolve out of a reversed attachment, as the render pass or rendering
/// instance declares it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthResolve {
    /// The resolve mode (never NONE).
    pub mode: vk::ResolveModeFlags,
    /// What the destination image is.
    pub destination: Target,
    /// The destination image (null when revz does not track its view).
    pub destination_image: vk::Image,
    /// Whether revz can swap MIN and MAX for this resolve (a twin render pass of one subpass,
    /// or a rendering instance; either where the device allows the swapped mode beside the
    /// stencil mode, [`ResolveSupport::swapped_depth_mode`]).
    pub swappable: bool,
}

impl DepthResolve {
    /// Why the reversed source of this resolve must become native, if it must: reversed
    /// values may only be resolved into a reversed image, and MIN or MAX pick the other sample
    /// on reversed values unless they are swapped. SAMPLE_ZERO and AVERAGE commute with every
    /// reversal revz makes (d -> 1 - d, and the affine map of infinite mode).
    pub fn demotes_source(&self) -> Option<NativeReason> {
        if self.destination != Target::Reversed {
            return Some(NativeReason::ResolvedIntoNative(self.destination_image));
        }
        let extreme = matches!(
            self.mode,
            vk::ResolveModeFlags::MIN | vk::ResolveModeFlags::MAX
        );
        (extreme && !self.swappable).then_some(NativeReason::UnswappableResolve)
    }
}

/// What a depth resolve between two tracked images makes of its destination, once its source's
/// own rule is applied ([`DepthResolve::demotes_source`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResolvedDestination {
    /// A native source (observable, or just made native) resolves standard values: its
    /// destination must hold standard depth too, for this reason.
    Demoted(NativeReason),
    /// Both ends are reversed (a reversed source stays so only into a reversed destination):
    /// the pair is remembered, for a later demotion of either end ([`follows_demotion`]).
    Paired,
}

/// What a resolve from `source` makes of its destination, where the source is still reversed
/// (`source_reversed`) or not after its own rule.
#[must_use]
pub fn resolved_destination(source: vk::Image, source_reversed: bool) -> ResolvedDestination {
    if source_reversed {
        ResolvedDestination::Paired
    } else {
        ResolvedDestination::Demoted(NativeReason::ResolvedFromNative(source))
    }
}

/// The end of a remembered resolve pair (`source`, `destination`: both were reversed) that
/// follows `demoted`, an end just made native, and why: a destination receives standard
/// values from a native source, and a source may not resolve reversed values into a native
/// destination.
#[must_use]
pub fn follows_demotion(
    (source, destination): (vk::Image, vk::Image),
    demoted: vk::Image,
) -> (vk::Image, NativeReason) {
    if source == demoted {
        (destination, NativeReason::ResolvedFromNative(source))
    } else {
        (source, NativeReason::ResolvedIntoNative(destination))
    }
}

/// What a device allows of depth/stencil resolves (`VkPhysicalDeviceDepthStencilResolveProperties`),
/// read at device creation: which depth modes it has, and which pairs of depth and stencil
/// modes one resolve may combine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResolveSupport {
    /// The depth resolve modes the device supports (SAMPLE_ZERO always).
    pub depth_modes: vk::ResolveModeFlags,
    /// `independentResolveNone`: depth and stencil may differ when one of them is NONE.
    pub independent_resolve_none: bool,
    /// `independentResolve`: any supported depth mode may go with any supported stencil mode.
    pub independent_resolve: bool,
}

impl ResolveSupport {
    /// What revz assumes of a device it cannot ask (below Vulkan 1.2): only SAMPLE_ZERO, the
    /// mode every device with depth resolves has, and the two modes always equal.
    pub const MINIMAL: ResolveSupport = ResolveSupport {
        depth_modes: vk::ResolveModeFlags::SAMPLE_ZERO,
        independent_resolve_none: false,
        independent_resolve: false,
    };

    /// Whether revz asks a device of API version `api` for its resolve properties
    /// (`VkPhysicalDeviceDepthStencilResolveProperties`, Vulkan 1.2); below it assumes
    /// [`Self::MINIMAL`].
    #[must_use]
    pub fn queried(api: u32) -> bool {
        api >= vk::API_VERSION_1_2
    }

    /// The support a device reports: its depth modes (`supported`), with SAMPLE_ZERO always
    /// (every device with depth resolves has it, whatever it reports), and its independence.
    #[must_use]
    pub fn reported(
        supported: vk::ResolveModeFlags,
        independent_resolve_none: bool,
        independent_resolve: bool,
    ) -> ResolveSupport {
        ResolveSupport {
            depth_modes: supported | vk::ResolveModeFlags::SAMPLE_ZERO,
            independent_resolve_none,
            independent_resolve,
        }
    }

    /// Whether one resolve may combine these depth and stencil modes, where the spec pairs
    /// them: equal modes always; one of them NONE with `independentResolveNone`; any pair with
    /// `independentResolve` as well (VUID-VkSubpassDescriptionDepthStencilResolve-
    /// pDepthStencilResolveAttachment-03185 and -03186, VUID-VkRenderingInfo-pDepthAttachment-
    /// 06104 and -06105).
    pub fn allows_pair(&self, depth: vk::ResolveModeFlags, stencil: vk::ResolveModeFlags) -> bool {
        let one_none = depth == vk::ResolveModeFlags::NONE || stencil == vk::ResolveModeFlags::NONE;
        // 06104 asks for independentResolveNone even where independentResolve is set (which
        // implies it on a conforming device): a device reporting one without the other gets
        // equal modes only.
        depth == stencil
            || (self.independent_resolve_none && (self.independent_resolve || one_none))
    }

    /// The depth mode a reversed attachment is resolved with in place of `depth` (MIN <-> MAX,
    /// others kept), or why the device does not allow it. Only the depth mode changes: stencil
    /// is never reversed, so `stencil` is kept, and the swapped depth mode must still pair with
    /// it. `stencil` is `None` where the spec does not pair the two (a render pass's resolve
    /// attachment without a stencil component, or a rendering instance without a stencil
    /// attachment view): then the stencil mode is ignored and cannot block the swap.
    pub fn swapped_depth_mode(
        &self,
        depth: vk::ResolveModeFlags,
        stencil: Option<vk::ResolveModeFlags>,
    ) -> Result<vk::ResolveModeFlags, &'static str> {
        let swapped = flip_resolve_mode(depth);
        if !self.depth_modes.contains(swapped) {
            return Err("the device does not support the swapped depth mode");
        }
        match stencil {
            Some(stencil) if !self.allows_pair(swapped, stencil) => {
                Err("the device does not allow the swapped depth mode beside the stencil mode")
            }
            _ => Ok(swapped),
        }
    }
}

/// How a reversed attachment's depth resolve goes down, where the resolve is in the command
/// itself (a rendering instance): as the application declares it, with MIN and MAX swapped,
/// or not at all reversed ([`ResolveSupport::reversed_resolve`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReversedResolve {
    /// The mode commutes with the reversal (NONE, SAMPLE_ZERO, AVERAGE): kept.
    Kept,
    /// MIN or MAX: resolved with this mode, the other one.
    Swapped(vk::ResolveModeFlags),
    /// The device does not allow the swapped mode (beside the stencil mode): the resolve's
    /// reversed source is made native (`DepthResolve::demotes_source`, for MIN and MAX), so no
    /// reversed attachment resolves with it.
    Unswappable,
}

impl ReversedResolve {
    /// Whether revz can resolve reversed depth with this resolve ([`DepthResolve::swappable`]).
    pub fn swappable(self) -> bool {
        self != ReversedResolve::Unswappable
    }

    /// The mode a reversed attachment is resolved with where the application asks for
    /// `app_mode`.
    pub fn mode(self, app_mode: vk::ResolveModeFlags) -> vk::ResolveModeFlags {
        match self {
            ReversedResolve::Swapped(mode) => mode,
            ReversedResolve::Kept | ReversedResolve::Unswappable => app_mode,
        }
    }
}

impl ResolveSupport {
    /// How a reversed attachment's resolve with `depth` goes down beside `stencil` (as
    /// [`Self::swapped_depth_mode`] pairs them): a mode the device allows for the reversed
    /// values, kept or swapped, or none.
    pub fn reversed_resolve(
        &self,
        depth: vk::ResolveModeFlags,
        stencil: Option<vk::ResolveModeFlags>,
    ) -> ReversedResolve {
        match self.swapped_depth_mode(depth, stencil) {
            Err(_) => ReversedResolve::Unswappable,
            Ok(mode) if mode == depth => ReversedResolve::Kept,
            Ok(mode) => ReversedResolve::Swapped(mode),
        }
    }
}

/// A subpass's depth resolve as its render pass declares it, for
/// [`ResolveSupport::twin_resolve`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SubpassResolveFacts {
    /// The depth resolve mode (never NONE).
    pub mode: vk::ResolveModeFlags,
    /// The stencil resolve mode, where the spec pairs it with the depth mode (a resolve
    /// attachment with a stencil component, or one revz cannot find: an index out of range);
    /// `None`: it is ignored.
    pub stencil: Option<vk::ResolveModeFlags>,
    /// The resolve structure comes first in the subpass's `pNext` chain: a copy linked in
    /// front of the chain then skips the original (elsewhere revz would have to copy
    /// structures it does not know).
    pub chained_first: bool,
}

/// Whether a render pass gets a twin whose MIN/MAX depth resolve is swapped, begun in its
/// place when the resolved attachment is reversed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TwinResolve {
    /// No subpass resolves depth with MIN or MAX: nothing to swap.
    Unneeded,
    /// A MIN/MAX resolve in a pass of several subpasses: resolve modes count for the
    /// compatibility of such passes, so no twin could be begun in its place.
    SeveralSubpasses,
    /// The pass's one subpass resolves with MIN or MAX, and revz cannot swap it: why.
    Unswappable(&'static str),
    /// The twin's subpass resolves depth with this mode (the stencil mode kept).
    Swapped(vk::ResolveModeFlags),
}

impl ResolveSupport {
    /// Whether a render pass whose subpasses resolve depth as `subpasses` says (`None`: no
    /// depth resolve) gets a swapped-resolve twin. Only a pass of one subpass can have one:
    /// for such passes resolve modes do not count for compatibility (Vulkan spec, "Render
    /// Pass Compatibility"), so the twin can be begun with the application's framebuffers,
    /// pipelines and secondaries. A resolve without a twin makes its reversed source native
    /// (`NativeReason::UnswappableResolve`).
    pub fn twin_resolve(
        &self,
        subpasses: impl IntoIterator<Item = Option<SubpassResolveFacts>>,
    ) -> TwinResolve {
        let (mut count, mut swaps, mut first) = (0usize, false, None);
        for resolve in subpasses {
            if count == 0 {
                first = resolve;
            }
            count += 1;
            swaps |= resolve.is_some_and(|r| flip_resolve_mode(r.mode) != r.mode);
        }
        if !swaps {
            return TwinResolve::Unneeded;
        }
        let (1, Some(resolve)) = (count, first) else {
            return TwinResolve::SeveralSubpasses;
        };
        match self.swapped_depth_mode(resolve.mode, resolve.stencil) {
            Err(why) => TwinResolve::Unswappable(why),
            Ok(_) if !resolve.chained_first => TwinResolve::Unswappable(
                "another structure precedes it in the subpass's pNext chain",
            ),
            Ok(mode) => TwinResolve::Swapped(mode),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reversed_resolve_source_stays_reversed_only_into_a_reversed_image() {
        let resolve = |mode, destination, swappable| DepthResolve {
            mode,
            destination,
            destination_image: vk::Image::null(),
            swappable,
        };
        use vk::ResolveModeFlags as M;
        for mode in [M::SAMPLE_ZERO, M::AVERAGE, M::MIN, M::MAX] {
            for destination in [Target::Native, Target::None] {
                assert!(matches!(
                    resolve(mode, destination, true).demotes_source(),
                    Some(NativeReason::ResolvedIntoNative(_))
                ));
            }
            assert_eq!(resolve(mode, Target::Reversed, true).demotes_source(), None);
        }
        assert_eq!(
            resolve(M::AVERAGE, Target::Reversed, false).demotes_source(),
            None
        );
        for mode in [M::MIN, M::MAX] {
            assert_eq!(
                resolve(mode, Target::Reversed, false).demotes_source(),
                Some(NativeReason::UnswappableResolve)
            );
        }
    }

    #[test]
    fn a_native_source_demotes_its_destination_and_reversed_ends_pair() {
        use vk::Handle;
        let (source, destination) = (vk::Image::from_raw(1), vk::Image::from_raw(2));
        assert_eq!(
            resolved_destination(source, false),
            ResolvedDestination::Demoted(NativeReason::ResolvedFromNative(source))
        );
        assert_eq!(
            resolved_destination(source, true),
            ResolvedDestination::Paired
        );
        // A demoted source takes its destination along, and a demoted destination its source.
        assert_eq!(
            follows_demotion((source, destination), source),
            (destination, NativeReason::ResolvedFromNative(source))
        );
        assert_eq!(
            follows_demotion((source, destination), destination),
            (source, NativeReason::ResolvedIntoNative(destination))
        );
    }

    /// Every support a device can report: (independentResolveNone, independentResolve).
    fn supports() -> impl Iterator<Item = ResolveSupport> {
        [(false, false), (true, false), (true, true), (false, true)]
            .into_iter()
            .map(|(none, all)| ResolveSupport {
                depth_modes: vk::ResolveModeFlags::SAMPLE_ZERO
                    | vk::ResolveModeFlags::AVERAGE
                    | vk::ResolveModeFlags::MIN
                    | vk::ResolveModeFlags::MAX,
                independent_resolve_none: none,
                independent_resolve: all,
            })
    }

    /// The spec's pairing rules, worded as its VUIDs are, for a pair the spec pairs: render
    /// passes (VkSubpassDescriptionDepthStencilResolve 03185, 03186) and dynamic rendering
    /// (VkRenderingInfo 06104, 06105).
    fn spec_allows(
        support: ResolveSupport,
        depth: vk::ResolveModeFlags,
        stencil: vk::ResolveModeFlags,
    ) -> bool {
        use vk::ResolveModeFlags as M;
        let (none, all) = (
            support.independent_resolve_none,
            support.independent_resolve,
        );
        let either_none = depth == M::NONE || stencil == M::NONE;
        let render_pass = match (all, none) {
            (false, false) => depth == stencil,
            (false, true) => depth == stencil || either_none,
            (true, _) => true,
        };
        let rendering = (none || depth == stencil) && (all || either_none || depth == stencil);
        render_pass && rendering
    }

    #[test]
    fn the_depth_resolve_swaps_only_into_a_pair_the_spec_allows_and_keeps_the_stencil_mode() {
        use vk::ResolveModeFlags as M;
        let stencils = [
            None,
            Some(M::NONE),
            Some(M::SAMPLE_ZERO),
            Some(M::MIN),
            Some(M::MAX),
        ];
        for support in supports() {
            for depth in [M::SAMPLE_ZERO, M::AVERAGE, M::MIN, M::MAX] {
                for stencil in stencils {
                    let swapped = flip_resolve_mode(depth);
                    let allowed = stencil.is_none_or(|s| spec_allows(support, swapped, s));
                    let expected = if allowed { Ok(swapped) } else { Err(()) };
                    assert_eq!(
                        support.swapped_depth_mode(depth, stencil).map_err(|_| ()),
                        expected,
                        "{support:?} {depth:?} {stencil:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn devices_are_asked_from_vulkan_1_2_and_always_have_sample_zero() {
        use vk::ResolveModeFlags as M;
        assert!(!ResolveSupport::queried(vk::API_VERSION_1_0));
        assert!(!ResolveSupport::queried(vk::API_VERSION_1_1));
        assert!(ResolveSupport::queried(vk::API_VERSION_1_2));
        assert!(ResolveSupport::queried(vk::API_VERSION_1_3));
        assert_eq!(
            ResolveSupport::reported(M::empty(), false, false),
            ResolveSupport::MINIMAL
        );
        assert_eq!(
            ResolveSupport::reported(M::MIN | M::MAX, true, false),
            ResolveSupport {
                depth_modes: M::SAMPLE_ZERO | M::MIN | M::MAX,
                independent_resolve_none: true,
                independent_resolve: false,
            }
        );
    }

    #[test]
    fn stencil_modes_block_a_swap_only_where_the_device_pairs_them_with_depth() {
        use vk::ResolveModeFlags as M;
        let mut support = supports().next().expect("a support");
        // Neither independence: the modes must stay equal, so a MIN beside a MIN stencil stays.
        assert!(support.swapped_depth_mode(M::MIN, Some(M::MIN)).is_err());
        // ... unless the stencil mode is ignored (no stencil in the resolve attachment).
        assert_eq!(support.swapped_depth_mode(M::MIN, None), Ok(M::MAX));
        // independentResolveNone: a NONE stencil mode is fine, a resolving one is not.
        support.independent_resolve_none = true;
        assert_eq!(
            support.swapped_depth_mode(M::MAX, Some(M::NONE)),
            Ok(M::MIN)
        );
        assert!(support.swapped_depth_mode(M::MAX, Some(M::MAX)).is_err());
        // independentResolve: any pair.
        support.independent_resolve = true;
        assert_eq!(support.swapped_depth_mode(M::MIN, Some(M::MIN)), Ok(M::MAX));
        assert_eq!(
            support.swapped_depth_mode(M::MIN, Some(M::SAMPLE_ZERO)),
            Ok(M::MAX)
        );
        // The swapped mode must be one the device has.
        support.depth_modes = M::SAMPLE_ZERO | M::MIN;
        assert!(support.swapped_depth_mode(M::MIN, None).is_err());
        assert_eq!(
            ResolveSupport::MINIMAL
                .swapped_depth_mode(M::AVERAGE, None)
                .map_err(|_| ()),
            Err(())
        );
        assert_eq!(
            ResolveSupport::MINIMAL.swapped_depth_mode(M::SAMPLE_ZERO, Some(M::SAMPLE_ZERO)),
            Ok(M::SAMPLE_ZERO)
        );
    }

    #[test]
    fn only_a_pass_of_one_subpass_with_a_swappable_min_max_resolve_gets_a_twin() {
        use vk::ResolveModeFlags as M;
        // independentResolveNone only.
        let support = supports().nth(1).expect("a support");
        let resolve = |mode, stencil, chained_first| {
            Some(SubpassResolveFacts {
                mode,
                stencil,
                chained_first,
            })
        };
        // Nothing to swap: no resolve, or modes that commute with the reversal.
        assert_eq!(support.twin_resolve([]), TwinResolve::Unneeded);
        assert_eq!(support.twin_resolve([None, None]), TwinResolve::Unneeded);
        for mode in [M::SAMPLE_ZERO, M::AVERAGE] {
            assert_eq!(
                support.twin_resolve([resolve(mode, None, true)]),
                TwinResolve::Unneeded
            );
        }
        // MIN or MAX in a pass of several subpasses, in any of them.
        assert_eq!(
            support.twin_resolve([None, resolve(M::MIN, None, true)]),
            TwinResolve::SeveralSubpasses
        );
        assert_eq!(
            support.twin_resolve([resolve(M::MAX, None, true), None]),
            TwinResolve::SeveralSubpasses
        );
        // One subpass: swapped where the device allows it and the structure comes first.
        assert_eq!(
            support.twin_resolve([resolve(M::MIN, None, true)]),
            TwinResolve::Swapped(M::MAX)
        );
        assert_eq!(
            support.twin_resolve([resolve(M::MAX, Some(M::NONE), true)]),
            TwinResolve::Swapped(M::MIN)
        );
        assert!(matches!(
            support.twin_resolve([resolve(M::MIN, Some(M::MIN), true)]),
            TwinResolve::Unswappable(_)
        ));
        assert_eq!(
            support.twin_resolve([resolve(M::MIN, None, false)]),
            TwinResolve::Unswappable("another structure precedes it in the subpass's pNext chain")
        );
        // The device's refusal is said before the chain's.
        assert_eq!(
            ResolveSupport::MINIMAL.twin_resolve([resolve(M::MIN, None, false)]),
            TwinResolve::Unswappable("the device does not support the swapped depth mode")
        );
    }

    #[test]
    fn a_reversed_rendering_resolve_is_kept_swapped_or_unswappable() {
        use vk::ResolveModeFlags as M;
        // independentResolveNone only.
        let support = supports().nth(1).expect("a support");
        for mode in [M::NONE, M::SAMPLE_ZERO, M::AVERAGE] {
            let resolve = support.reversed_resolve(mode, None);
            assert_eq!(resolve, ReversedResolve::Kept);
            assert!(resolve.swappable());
            assert_eq!(resolve.mode(mode), mode);
        }
        for (mode, swapped) in [(M::MIN, M::MAX), (M::MAX, M::MIN)] {
            let resolve = support.reversed_resolve(mode, Some(M::NONE));
            assert_eq!(resolve, ReversedResolve::Swapped(swapped));
            assert!(resolve.swappable());
            assert_eq!(resolve.mode(mode), swapped);
            // Beside a resolving stencil mode the swap is not allowed here.
            let blocked = support.reversed_resolve(mode, Some(mode));
            assert_eq!(blocked, ReversedResolve::Unswappable);
            assert!(!blocked.swappable());
            assert_eq!(blocked.mode(mode), mode);
        }
        // A mode the device lacks cannot resolve reversed values either.
        assert_eq!(
            ResolveSupport::MINIMAL.reversed_resolve(M::AVERAGE, None),
            ReversedResolve::Unswappable
        );
    }
}
