//! Render pass instances and the twins revz begins in their place: the storage a
//! framebuffer's depth attachments have ([`FramebufferStorage::of`]: promoted or not, or a mix
//! no pass takes), which twin a pass begin uses ([`PassTwin::choose`]), whether a pass's
//! depth resolve can be swapped ([`pass_resolve_swappable`]), and at a begin: which target it
//! commits ([`pass_committed`]), which of its clear values are of reversed attachments
//! ([`clears_reversed`]: the first commits the convention, and they flip), and whether it
//! resolves a reversed attachment ([`resolves_reversed`]); for promotion: the formats of a
//! pass's promoted twin ([`promoted_twin_format`]), which framebuffers are considered for it
//! ([`framebuffer_may_be_promoted`], [`pass_promotable`]), and the view formats an imageless one lists
//! ([`imageless_view_format`]); at a pass's creation: whether it gets a promoted twin
//! ([`has_promoted_twin`]) and which of its attachments a begin clears the depth of
//! ([`clears_depth_at_begin`]); at a subpass and at a rendering begin: the format a promoted
//! instance's draws convert from ([`subpass_promoted_from`], [`rendering_promoted_from`]).

use ash::vk;

use crate::command_state::Target;

/// Whether a framebuffer's promotable depth attachments are promoted images: all (it is
/// created with the pass's promoted twin), none, or some (a mix no pass can take).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FramebufferStorage {
    Unpromoted,
    Promoted,
    Mixed,
}

impl FramebufferStorage {
    /// The storage of a framebuffer whose promotable attachments are each `promoted` or not.
    pub fn of(promoted: impl Iterator<Item = bool>) -> FramebufferStorage {
        let (mut any, mut all) = (false, true);
        for promoted in promoted {
            any |= promoted;
            all &= promoted;
        }
        match (any, all) {
            (false, _) => FramebufferStorage::Unpromoted,
            (true, true) => FramebufferStorage::Promoted,
            (true, false) => FramebufferStorage::Mixed,
        }
    }
}

/// The render pass a pass begin uses in place of the application's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassTwin {
    /// The application's own pass.
    Application,
    /// Its twin with MIN and MAX depth resolves swapped (none where the pass has none to swap:
    /// the application's then).
    SwappedResolve,
    /// Its twin with float depth formats.
    Promoted,
    /// Its twin with float depth formats and MIN and MAX depth resolves swapped.
    PromotedSwapped,
}

impl PassTwin {
    /// The twin a pass begins as: promoted where its framebuffer's depth images are
    /// (`promoted`: it was created with the promoted twin, so only a promoted twin is
    /// compatible with it), with swapped resolves where a reversed attachment is resolved
    /// (`resolved_reversed`), both where both hold. A pass whose resolves need no swap has no
    /// swapped twin (`has_swapped_twin`), and a promoted framebuffer still needs the promoted
    /// one.
    pub fn choose(promoted: bool, resolved_reversed: bool, has_swapped_twin: bool) -> PassTwin {
        match (promoted, resolved_reversed) {
            (false, false) => PassTwin::Application,
            (false, true) => PassTwin::SwappedResolve,
            (true, false) => PassTwin::Promoted,
            (true, true) if !has_swapped_twin => PassTwin::Promoted,
            (true, true) => PassTwin::PromotedSwapped,
        }
    }
}

/// Whether a render pass's depth resolve with `mode` can be swapped: a mode other than MIN and
/// MAX needs no swap, and MIN or MAX can be swapped where the pass has its swapped-resolve twin
/// (`has_swapped_twin`, `crate::policy::ResolveSupport::twin_resolve`).
pub fn pass_resolve_swappable(mode: vk::ResolveModeFlags, has_swapped_twin: bool) -> bool {
    !matches!(mode, vk::ResolveModeFlags::MIN | vk::ResolveModeFlags::MAX) || has_swapped_twin
}

/// The target a render pass begin commits (`crate::policy::Observed::committed`): reversed
/// where any of its attachments (`images`, as created) is, at once; else none.
pub fn pass_committed(images: &[Target]) -> Target {
    if images.contains(&Target::Reversed) {
        Target::Reversed
    } else {
        Target::None
    }
}

/// Whether a render pass begin's clear value at an attachment is the depth clear of a reversed
/// attachment: the pass clears that attachment's depth (`cleared`, from its load op) and the
/// attachment is reversed (`target`; `None`: the framebuffer has no attachment there). Over the
/// attachments as created, the first such clear commits the convention with its value; over
/// them after the convention, each such clear value flips. A dynamic rendering's depth
/// attachment follows the same rule (`vkCmdBeginRendering`).
pub fn clears_reversed(cleared: bool, target: Option<Target>) -> bool {
    cleared && target == Some(Target::Reversed)
}

/// Whether a render pass begin resolves a reversed attachment: the source of one of its depth
/// resolves (`sources`, attachment indices) is reversed in `targets` (after the convention).
/// Sources were settled before (a reversed source resolves into a reversed image), so the pass
/// begins with its swapped-resolve twin ([`PassTwin::choose`]).
pub fn resolves_reversed(sources: impl IntoIterator<Item = u32>, targets: &[Target]) -> bool {
    sources
        .into_iter()
        .any(|source| targets.get(source as usize) == Some(&Target::Reversed))
}

/// The format an attachment of a render pass's promoted twin has in place of the
/// application's (`format`): the float format of a UNORM depth format, every one (the twin is
/// begun only over framebuffers of promoted images); `None`: it keeps its format. A pass
/// without such an attachment has no promoted twin.
pub fn promoted_twin_format(format: vk::Format) -> Option<vk::Format> {
    crate::conv::float_depth_format(format)
}

/// Whether a render pass gets a promoted twin: promotion is on (`promote`) and the twin
/// changes the format of one of its attachments (`changes_a_format`: whether
/// [`promoted_twin_format`] gave any a float format; asked only where promotion is on, as it
/// reads the pass's attachments). A pass without a UNORM depth attachment needs no twin: its
/// framebuffers are never promoted.
pub fn has_promoted_twin(promote: bool, changes_a_format: impl FnOnce() -> bool) -> bool {
    promote && changes_a_format()
}

/// Whether a render pass begin clears the depth of an attachment of `format` with `load_op`:
/// its format has depth and it is loaded with CLEAR (a stencil-only attachment's clear has no
/// depth, and a depth/stencil one's stencil load op does not count). Recorded per attachment
/// at the pass's creation, read at its begins ([`clears_reversed`]).
pub fn clears_depth_at_begin(format: vk::Format, load_op: vk::AttachmentLoadOp) -> bool {
    crate::conv::has_depth(format) && load_op == vk::AttachmentLoadOp::CLEAR
}

/// Whether an input attachment reference reads depth: an attachment with a depth aspect,
/// referenced with the depth aspect (`aspect` empty: not given, which reads every aspect of
/// the view; a shader reading it as floats reads depth).
pub fn reads_depth_input(format: Option<vk::Format>, aspect: vk::ImageAspectFlags) -> bool {
    format.is_some_and(crate::conv::has_depth)
        && (aspect.is_empty() || aspect.contains(vk::ImageAspectFlags::DEPTH))
}

/// The format a render pass instance's draws convert from in a subpass: `None` outside a
/// promoted twin (`promoted`: the pass was begun as its twin); else the UNORM format of the
/// subpass's depth attachment (`depth_format`), or UNDEFINED where it has none or its format is
/// not one revz promotes (the pass is still the twin, its pipelines' promoted variants apply,
/// but no bias converts).
pub fn subpass_promoted_from(
    promoted: bool,
    depth_format: Option<vk::Format>,
) -> Option<vk::Format> {
    promoted.then(|| {
        depth_format
            .filter(|&format| crate::policy::promotable_format(format))
            .unwrap_or(vk::Format::UNDEFINED)
    })
}

/// The format a dynamic rendering instance's draws convert from, where it draws into promoted
/// attachments (their pipelines' and secondaries' promoted variants were made with float
/// rendering formats): the first of its depth and stencil attachments' views (`views`, in that
/// order) of a promoted image (`promoted`, asked in order until one is) makes it promoted, with
/// the format of that view's image (`format`, asked of that view only; UNDEFINED where revz
/// does not know it). `None`: no view is of a promoted image.
pub fn rendering_promoted_from<V: Copy>(
    views: impl IntoIterator<Item = V>,
    mut promoted: impl FnMut(V) -> bool,
    format: impl FnOnce(V) -> Option<vk::Format>,
) -> Option<vk::Format> {
    views
        .into_iter()
        .find(|&view| promoted(view))
        .map(|view| format(view).unwrap_or(vk::Format::UNDEFINED))
}

/// Whether a framebuffer is considered for promotion: promotion is on (`promote`) and its pass
/// has an attachment revz promotes (`promotable`: each attachment's, asked in order until one
/// is, and only where promotion is on).
pub fn framebuffer_may_be_promoted(
    promote: bool,
    promotable: impl IntoIterator<Item = bool>,
) -> bool {
    promote && pass_promotable(promotable)
}

/// Whether a render pass has an attachment revz promotes (`promotable`: each attachment's,
/// asked in order until one is): the passes a framebuffer, a pipeline or a secondary's
/// inheritance may be promoted with, where promotion is on.
pub fn pass_promotable(promotable: impl IntoIterator<Item = bool>) -> bool {
    promotable.into_iter().any(|promotable| promotable)
}

/// The format an imageless framebuffer of promoted images lists for an attachment's views, in
/// place of the application's `view_format`: the float one where it is the pass's UNORM format
/// of the attachment (`attachment_format`; `None`: the pass has no such attachment) and the
/// attachment is promotable (`promotable`); else as listed.
pub fn imageless_view_format(
    view_format: vk::Format,
    attachment_format: Option<vk::Format>,
    promotable: bool,
) -> vk::Format {
    match crate::conv::float_depth_format(view_format) {
        Some(float) if Some(view_format) == attachment_format && promotable => float,
        _ => view_format,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_promoted_twin_has_the_float_depth_formats() {
        use vk::Format as F;
        assert_eq!(promoted_twin_format(F::D16_UNORM), Some(F::D32_SFLOAT));
        assert_eq!(
            promoted_twin_format(F::D24_UNORM_S8_UINT),
            Some(F::D32_SFLOAT_S8_UINT)
        );
        assert_eq!(promoted_twin_format(F::D32_SFLOAT), None);
        assert_eq!(promoted_twin_format(F::R8G8B8A8_UNORM), None);
    }

    #[test]
    fn a_pass_has_a_promoted_twin_where_promotion_is_on_and_a_format_changes() {
        assert!(has_promoted_twin(true, || true));
        assert!(!has_promoted_twin(true, || false));
        // The attachments are not read where promotion is off.
        assert!(!has_promoted_twin(false, || unreachable!()));
    }

    #[test]
    fn a_begin_clears_the_depth_of_depth_attachments_loaded_with_clear() {
        use vk::AttachmentLoadOp as L;
        use vk::Format as F;
        for format in [F::D16_UNORM, F::D32_SFLOAT, F::D24_UNORM_S8_UINT] {
            assert!(clears_depth_at_begin(format, L::CLEAR));
            for load_op in [L::LOAD, L::DONT_CARE, L::NONE_EXT] {
                assert!(!clears_depth_at_begin(format, load_op));
            }
        }
        // Stencil-only and color attachments clear no depth.
        assert!(!clears_depth_at_begin(F::S8_UINT, L::CLEAR));
        assert!(!clears_depth_at_begin(F::R8G8B8A8_UNORM, L::CLEAR));
    }

    #[test]
    fn a_promoted_subpass_converts_from_its_depth_attachments_unorm_format() {
        use vk::Format as F;
        assert_eq!(
            subpass_promoted_from(false, Some(F::D24_UNORM_S8_UINT)),
            None
        );
        assert_eq!(subpass_promoted_from(false, None), None);
        assert_eq!(
            subpass_promoted_from(true, Some(F::D24_UNORM_S8_UINT)),
            Some(F::D24_UNORM_S8_UINT)
        );
        assert_eq!(
            subpass_promoted_from(true, Some(F::D16_UNORM)),
            Some(F::D16_UNORM)
        );
        // Still the twin, but nothing to convert: no depth attachment, or a float one.
        assert_eq!(subpass_promoted_from(true, None), Some(F::UNDEFINED));
        assert_eq!(
            subpass_promoted_from(true, Some(F::D32_SFLOAT)),
            Some(F::UNDEFINED)
        );
    }

    #[test]
    fn the_first_promoted_rendering_view_gives_the_format_draws_convert_from() {
        use vk::Format as F;
        // Views: (promoted, format).
        let views = |views: &[(bool, Option<F>)]| {
            let mut asked = Vec::new();
            let mut formats = Vec::new();
            let from = rendering_promoted_from(
                views.iter().copied().enumerate(),
                |(index, (promoted, _))| {
                    asked.push(index);
                    promoted
                },
                |(index, (_, format))| {
                    formats.push(index);
                    format
                },
            );
            (from, asked, formats)
        };
        assert_eq!(views(&[]), (None, vec![], vec![]));
        assert_eq!(
            views(&[(false, Some(F::D16_UNORM)), (false, Some(F::S8_UINT))]),
            (None, vec![0, 1], vec![])
        );
        // The depth view first: the stencil view is not asked once it is promoted.
        assert_eq!(
            views(&[
                (true, Some(F::D16_UNORM)),
                (true, Some(F::D24_UNORM_S8_UINT))
            ]),
            (Some(F::D16_UNORM), vec![0], vec![0])
        );
        assert_eq!(
            views(&[
                (false, Some(F::D16_UNORM)),
                (true, Some(F::D24_UNORM_S8_UINT))
            ]),
            (Some(F::D24_UNORM_S8_UINT), vec![0, 1], vec![1])
        );
        // A promoted view of an image revz does not know the format of.
        assert_eq!(
            views(&[(true, None)]),
            (Some(F::UNDEFINED), vec![0], vec![0])
        );
    }

    #[test]
    fn a_pass_is_promotable_with_any_promotable_attachment() {
        assert!(pass_promotable([false, true]));
        assert!(!pass_promotable([false, false]));
        assert!(!pass_promotable([]));
    }

    #[test]
    fn a_framebuffer_is_considered_for_promotion_where_its_pass_is_promotable() {
        assert!(framebuffer_may_be_promoted(true, [false, true]));
        assert!(!framebuffer_may_be_promoted(true, [false]));
        assert!(!framebuffer_may_be_promoted(true, []));
        assert!(!framebuffer_may_be_promoted(false, [true]));
    }

    #[test]
    fn an_imageless_framebuffer_lists_the_float_format_for_its_promotable_unorm_attachment() {
        use vk::Format as F;
        let d16 = Some(F::D16_UNORM);
        assert_eq!(
            imageless_view_format(F::D16_UNORM, d16, true),
            F::D32_SFLOAT
        );
        assert_eq!(
            imageless_view_format(F::D16_UNORM, d16, false),
            F::D16_UNORM
        );
        assert_eq!(
            imageless_view_format(F::D16_UNORM, Some(F::D24_UNORM_S8_UINT), true),
            F::D16_UNORM
        );
        assert_eq!(
            imageless_view_format(F::D16_UNORM, None, true),
            F::D16_UNORM
        );
        assert_eq!(
            imageless_view_format(F::R16_UNORM, Some(F::R16_UNORM), true),
            F::R16_UNORM
        );
    }

    #[test]
    fn a_pass_commits_reversed_where_any_attachment_is() {
        use Target::{Native, None, Reversed};
        assert_eq!(pass_committed(&[]), None);
        assert_eq!(pass_committed(&[None, Native]), None);
        assert_eq!(pass_committed(&[Native, Reversed]), Reversed);
        assert_eq!(pass_committed(&[Reversed]), Reversed);
    }

    #[test]
    fn only_cleared_reversed_attachments_clear_reversed() {
        assert!(clears_reversed(true, Some(Target::Reversed)));
        assert!(!clears_reversed(false, Some(Target::Reversed)));
        for target in [None, Some(Target::None), Some(Target::Native)] {
            assert!(!clears_reversed(true, target));
            assert!(!clears_reversed(false, target));
        }
    }

    #[test]
    fn a_pass_resolves_reversed_where_a_resolve_source_is_reversed() {
        use Target::{Native, Reversed};
        let targets = [Native, Reversed];
        assert!(!resolves_reversed([], &targets));
        assert!(!resolves_reversed([0], &targets));
        assert!(resolves_reversed([1], &targets));
        assert!(resolves_reversed([0, 1], &targets));
        // A source beyond the framebuffer's attachments resolves nothing reversed.
        assert!(!resolves_reversed([2], &targets));
        assert!(!resolves_reversed([0], &[]));
    }

    #[test]
    fn a_framebuffer_is_promoted_only_where_all_its_promotable_attachments_are() {
        let of = |promoted: &[bool]| FramebufferStorage::of(promoted.iter().copied());
        assert_eq!(of(&[]), FramebufferStorage::Unpromoted);
        assert_eq!(of(&[false, false]), FramebufferStorage::Unpromoted);
        assert_eq!(of(&[true]), FramebufferStorage::Promoted);
        assert_eq!(of(&[true, true]), FramebufferStorage::Promoted);
        assert_eq!(of(&[true, false]), FramebufferStorage::Mixed);
        assert_eq!(of(&[false, true]), FramebufferStorage::Mixed);
    }

    #[test]
    fn a_pass_begins_as_the_twin_of_its_storage_and_resolves() {
        use PassTwin::{Application, Promoted, PromotedSwapped, SwappedResolve};
        for has_swapped_twin in [false, true] {
            assert_eq!(
                PassTwin::choose(false, false, has_swapped_twin),
                Application
            );
            assert_eq!(
                PassTwin::choose(false, true, has_swapped_twin),
                SwappedResolve
            );
            assert_eq!(PassTwin::choose(true, false, has_swapped_twin), Promoted);
        }
        assert_eq!(PassTwin::choose(true, true, false), Promoted);
        assert_eq!(PassTwin::choose(true, true, true), PromotedSwapped);
    }

    #[test]
    fn only_min_and_max_resolves_need_the_swapped_twin() {
        use vk::ResolveModeFlags as M;
        for mode in [M::SAMPLE_ZERO, M::AVERAGE] {
            assert!(pass_resolve_swappable(mode, false));
            assert!(pass_resolve_swappable(mode, true));
        }
        for mode in [M::MIN, M::MAX] {
            assert!(!pass_resolve_swappable(mode, false));
            assert!(pass_resolve_swappable(mode, true));
        }
    }
}
