//! Secondary command buffers without a framebuffer in their inheritance info: where one
//! draws ([`secondary_target`]) and whether into a promoted attachment
//! ([`secondary_promoted`]), and what a secondary's inheritance of a pass and depth format
//! makes of them ([`inherited_target`], [`inherited_promoted`]). Which inheritances may
//! continue a promoted pass at all follows the passes' and formats' rules
//! (`crate::policy::pass_promotable`, `crate::policy::first_promoted_format`, and the float
//! formats a promoted one inherits, `crate::policy::promoted_attachment_format`).

use ash::vk;

use crate::command_state::Target;

/// Where a secondary command buffer without a framebuffer in its inheritance info draws: the
/// target a primary last began that subpass or rendering format with for secondaries
/// (`remembered`), else what the device's live depth images of the format are (`reversed`
/// and `native` counts). Returns the target and whether it is a guess between images of both
/// kinds (then reversed, since non-observable attachments, the ones secondaries usually draw
/// into, are reversed; logged once by the caller).
pub fn secondary_target(
    remembered: Option<Target>,
    reversed: usize,
    native: usize,
) -> (Target, bool) {
    if let Some(target) = remembered {
        return (target, false);
    }
    match (reversed, native) {
        (0, 0) => (Target::None, false),
        (_, 0) => (Target::Reversed, false),
        (0, _) => (Target::Native, false),
        _ => (Target::Reversed, true),
    }
}

/// Whether a secondary without a framebuffer draws into a promoted attachment: as its pass was
/// last begun for secondaries, else as the device's live images of its depth format are
/// (`promoted` of them promoted, `kept` not). Returns whether it is, and whether that was a
/// guess between both kinds (promoted is assumed: in a promoting mode, the images that keep
/// their format are the ones copied from, rarely drawn by secondaries).
pub fn secondary_promoted(remembered: Option<bool>, promoted: usize, kept: usize) -> (bool, bool) {
    match (remembered, promoted, kept) {
        (Some(remembered), _, _) => (remembered, false),
        (None, 0, _) => (false, false),
        (None, _, 0) => (true, false),
        (None, _, _) => (true, true),
    }
}

/// The depth target a secondary continuing a pass draws into (before the application's
/// convention applies): that of the framebuffer its inheritance names (`framebuffer`: where it
/// names the framebuffer's views); else, where the pass has a depth `format`,
/// [`secondary_target`] of the target that pass was last begun with for secondaries
/// (`remembered`, asked only then), else of the device's live images of the format (`images`:
/// how many are reversed and native, asked only where nothing is remembered); else none. An
/// imageless framebuffer names no views (they are given at each begin, and may differ from one
/// to the next): its pass decides as without a framebuffer. Returns the target and whether it
/// is a guess.
pub fn inherited_target(
    framebuffer: Option<Target>,
    format: Option<vk::Format>,
    remembered: impl FnOnce() -> Option<Target>,
    images: impl FnOnce(vk::Format) -> (usize, usize),
) -> (Target, bool) {
    if let Some(target) = framebuffer {
        return (target, false);
    }
    let Some(format) = format else {
        return (Target::None, false);
    };
    let remembered = remembered();
    let (reversed, native) = match remembered {
        Some(_) => (0, 0),
        None => images(format),
    };
    secondary_target(remembered, reversed, native)
}

/// Whether a secondary continuing a pass draws into a promoted attachment, and the UNORM
/// depth format its draws convert from ([`crate::policy::subpass_promoted_from`] of its depth
/// `format`; `None`: the pass has no depth attachment): as the framebuffer its inheritance
/// names was created (`framebuffer`: whether promoted, where revz tracks it; an imageless one
/// too, as its attachment infos fixed its storage); else [`secondary_promoted`] of how that
/// pass was last begun for secondaries (`remembered`, asked only then), else of the device's
/// live images of the format (`images`: how many are promoted and kept, asked only where
/// nothing is remembered and there is a format). Returns the format (`None`: not promoted) and
/// whether it is a guess.
pub fn inherited_promoted(
    framebuffer: Option<bool>,
    format: Option<vk::Format>,
    remembered: impl FnOnce() -> Option<bool>,
    images: impl FnOnce(vk::Format) -> (usize, usize),
) -> (Option<vk::Format>, bool) {
    if let Some(promoted) = framebuffer {
        return (
            crate::policy::subpass_promoted_from(promoted, format),
            false,
        );
    }
    let remembered = remembered();
    let (promoted, kept) = match (remembered, format) {
        (None, Some(format)) => images(format),
        _ => (0, 0),
    };
    let (promoted, guessed) = secondary_promoted(remembered, promoted, kept);
    (
        crate::policy::subpass_promoted_from(promoted, format),
        guessed,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secondaries_follow_the_pass_then_the_formats_images() {
        assert_eq!(secondary_promoted(Some(false), 3, 0), (false, false));
        assert_eq!(secondary_promoted(Some(true), 0, 3), (true, false));
        assert_eq!(secondary_promoted(None, 0, 0), (false, false));
        assert_eq!(secondary_promoted(None, 0, 2), (false, false));
        assert_eq!(secondary_promoted(None, 2, 0), (true, false));
        assert_eq!(secondary_promoted(None, 2, 1), (true, true));
    }

    #[test]
    fn a_secondary_without_framebuffer_follows_the_pass_it_was_last_begun_for() {
        // A sampled (native) shadow map and a reversed main attachment of one format: the
        // shadow pass, once begun for secondaries, is known to be native.
        assert_eq!(
            secondary_target(Some(Target::Native), 1, 1),
            (Target::Native, false)
        );
        assert_eq!(
            secondary_target(Some(Target::Reversed), 0, 1),
            (Target::Reversed, false)
        );
        // Never begun yet: the images of the format decide, a guess only where both kinds
        // exist.
        assert_eq!(secondary_target(None, 1, 1), (Target::Reversed, true));
        assert_eq!(secondary_target(None, 0, 2), (Target::Native, false));
        assert_eq!(secondary_target(None, 3, 0), (Target::Reversed, false));
        assert_eq!(secondary_target(None, 0, 0), (Target::None, false));
    }

    #[test]
    fn an_inherited_target_counts_the_formats_images_only_where_nothing_is_remembered() {
        let d32 = Some(vk::Format::D32_SFLOAT);
        let never = |_| -> (usize, usize) { panic!("counted") };
        let unasked = || -> Option<Target> { panic!("remembered asked") };
        assert_eq!(
            inherited_target(None, d32, || Some(Target::Native), never),
            (Target::Native, false)
        );
        let mut asked = None;
        let counted = inherited_target(
            None,
            d32,
            || None,
            |format| {
                asked = Some(format);
                (1, 1)
            },
        );
        assert_eq!((counted, asked), ((Target::Reversed, true), d32));
        assert_eq!(
            inherited_target(None, d32, || None, |_| (0, 2)),
            (Target::Native, false)
        );
        assert_eq!(
            inherited_target(None, d32, || None, |_| (0, 0)),
            (Target::None, false)
        );
        // A framebuffer that names its views decides; a pass without depth draws into none.
        assert_eq!(
            inherited_target(Some(Target::Native), d32, unasked, never),
            (Target::Native, false)
        );
        assert_eq!(
            inherited_target(Some(Target::None), d32, unasked, never),
            (Target::None, false)
        );
        assert_eq!(
            inherited_target(None, None, unasked, never),
            (Target::None, false)
        );
    }

    #[test]
    fn an_inherited_promotion_names_the_unorm_format_draws_convert_from() {
        let (d24, d32) = (vk::Format::D24_UNORM_S8_UINT, vk::Format::D32_SFLOAT);
        let never = |_| -> (usize, usize) { panic!("counted") };
        let unasked = || -> Option<bool> { panic!("remembered asked") };
        // The framebuffer's creation decides where revz tracks it, imageless ones too.
        assert_eq!(
            inherited_promoted(Some(true), Some(d24), unasked, never),
            (Some(d24), false)
        );
        assert_eq!(
            inherited_promoted(Some(false), Some(d24), unasked, never),
            (None, false)
        );
        // Remembered: the images are not counted.
        assert_eq!(
            inherited_promoted(None, Some(d24), || Some(true), never),
            (Some(d24), false)
        );
        assert_eq!(
            inherited_promoted(None, Some(d24), || Some(false), never),
            (None, false)
        );
        // No depth format: nothing to count, and a remembered promotion converts nothing.
        assert_eq!(
            inherited_promoted(None, None, || None, never),
            (None, false)
        );
        assert_eq!(
            inherited_promoted(None, None, || Some(true), never),
            (Some(vk::Format::UNDEFINED), false)
        );
        // A format revz does not promote converts nothing either.
        assert_eq!(
            inherited_promoted(None, Some(d32), || Some(true), never),
            (Some(vk::Format::UNDEFINED), false)
        );
        // Counted: promoted images only, kept ones only, both (a guess).
        assert_eq!(
            inherited_promoted(None, Some(d24), || None, |_| (2, 0)),
            (Some(d24), false)
        );
        assert_eq!(
            inherited_promoted(None, Some(d24), || None, |_| (0, 2)),
            (None, false)
        );
        assert_eq!(
            inherited_promoted(None, Some(d24), || None, |_| (1, 1)),
            (Some(d24), true)
        );
    }
}
