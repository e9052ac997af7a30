//! Render pass instances and the twins revz begins in their place: the storage a
//! framebuffer's depth attachments have ([`FramebufferStorage::of`]: promoted or not, or a mix
//! no pass takes), which twin a pass begin uses ([`PassTwin::choose`]), and whether a pass's
//! depth resolve can be swapped ([`pass_resolve_swappable`]).

use ash::vk;

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

#[cfg(test)]
mod tests {
    use super::*;

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
