//! Clears recorded outside pass begins: which of `vkCmdClearAttachments`' clears flip
//! ([`attachment_clears_flip`], [`flips_attachment_clear`]), which image clears revz looks at
//! ([`image_clear_considered`]), and whether an image clear writes depth, so that its value
//! says anything of the convention ([`clears_depth`]). Pass begins'
//! clear values are in `passes.rs`; the flipped value itself is
//! [`super::DevicePolicy::reversed_clear`].

use ash::vk;

use crate::command_state::Target;

/// Whether any of a `vkCmdClearAttachments`' clears may flip: draws go to a reversed attachment
/// (`target`, after the convention). Elsewhere the application's clears go down untouched.
pub fn attachment_clears_flip(target: Target) -> bool {
    target == Target::Reversed
}

/// Whether a `vkCmdClearAttachments` clear of `aspect` flips its depth value: it clears the
/// depth aspect of a reversed attachment (`target`); a colour or stencil-only clear keeps its
/// value.
pub fn flips_attachment_clear(target: Target, aspect: vk::ImageAspectFlags) -> bool {
    attachment_clears_flip(target) && aspect.contains(vk::ImageAspectFlags::DEPTH)
}

/// Whether revz looks at a `vkCmdClearDepthStencilImage` at all: only a clear of a reversed
/// image (`reversed`, as created) commits the convention or may flip
/// ([`super::Observed::committed`] commits nothing for other images, and their clears keep
/// their values), so the clear's value and ranges are read only then.
pub fn image_clear_considered(reversed: bool) -> bool {
    reversed
}

/// Whether an image clear writes depth: a range of the depth aspect (a stencil-only clear
/// leaves depth, and says nothing of its convention).
pub fn clears_depth(ranges: &[vk::ImageSubresourceRange]) -> bool {
    ranges
        .iter()
        .any(|range| range.aspect_mask.contains(vk::ImageAspectFlags::DEPTH))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_depth_clears_of_a_reversed_target_flip() {
        use vk::ImageAspectFlags as A;
        assert!(attachment_clears_flip(Target::Reversed));
        for target in [Target::None, Target::Native] {
            assert!(!attachment_clears_flip(target));
            for aspect in [A::DEPTH, A::DEPTH | A::STENCIL, A::STENCIL, A::COLOR] {
                assert!(!flips_attachment_clear(target, aspect));
            }
        }
        assert!(flips_attachment_clear(Target::Reversed, A::DEPTH));
        assert!(flips_attachment_clear(
            Target::Reversed,
            A::DEPTH | A::STENCIL
        ));
        assert!(!flips_attachment_clear(Target::Reversed, A::STENCIL));
        assert!(!flips_attachment_clear(Target::Reversed, A::COLOR));
    }

    #[test]
    fn only_clears_of_reversed_images_are_considered() {
        assert!(image_clear_considered(true));
        assert!(!image_clear_considered(false));
    }

    #[test]
    fn only_clears_of_the_depth_aspect_say_anything_about_depth() {
        let range = |aspect_mask| vk::ImageSubresourceRange {
            aspect_mask,
            level_count: 1,
            layer_count: 1,
            ..Default::default()
        };
        use vk::ImageAspectFlags as A;
        assert!(!clears_depth(&[range(A::STENCIL)]));
        assert!(!clears_depth(&[]));
        assert!(clears_depth(&[range(A::DEPTH)]));
        assert!(clears_depth(&[
            range(A::STENCIL),
            range(A::DEPTH | A::STENCIL)
        ]));
    }
}
