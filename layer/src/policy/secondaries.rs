//! Secondary command buffers without a framebuffer in their inheritance info: where one
//! draws ([`secondary_target`]) and whether into a promoted attachment
//! ([`secondary_promoted`]).

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
}
