//! Dynamic depth bias: whether a `vkCmdSetDepthBias2EXT` is replayed for each draw's target or
//! sent once as it is recorded ([`BiasRecording::of`]). Which bias a draw then sends for its
//! attachment (float units where promoted, negated where reversed) is a conversion:
//! `crate::conv::DepthBias::for_attachment`.

/// How revz records a `vkCmdSetDepthBias2EXT`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BiasRecording {
    /// Held in the command buffer's state and sent for each draw's target, as
    /// `vkCmdSetDepthBias` is: revz can send it again with the representation it came with.
    PerDraw,
    /// Sent down at once, for the target current where it is recorded: its chain holds
    /// structures revz cannot keep to send again later (a target that changes before the draw
    /// is not followed).
    AtRecord,
}

impl BiasRecording {
    /// The recording of a bias whose chain holds nothing (`only_representation`: nothing but a
    /// `VkDepthBiasRepresentationInfoEXT`, or no structure at all) or more.
    pub fn of(only_representation: bool) -> BiasRecording {
        if only_representation {
            BiasRecording::PerDraw
        } else {
            BiasRecording::AtRecord
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_bias_revz_can_send_again_follows_each_draws_target() {
        assert_eq!(BiasRecording::of(true), BiasRecording::PerDraw);
        assert_eq!(BiasRecording::of(false), BiasRecording::AtRecord);
    }
}
