//! The push shortcut (issue #42): what a push of the application's does to a settled command
//! buffer, decided in a few compares where nothing revz sends changes with it.
//!
//! Most pushes of a frame are the same camera's matrices (P * V * M per object) pushed with
//! the layout of the last push, into a state that already settled: the carrier revz holds is
//! right for them, the draw's path stays, and only the shadow copy of the bytes changes. For
//! such a state, [`CommandState::refresh_shortcut`] writes down, where the state becomes
//! settled, the two answers [`CommandState::push_constants`] would give: a push that misses
//! the bound pipeline's projection changes nothing revz sends; one that writes it changes
//! nothing as long as its matrix classifies as the settled outcome
//! ([`crate::precise::PushConstants::keeps`]: the last matrix's bits, or surely the same
//! camera's). [`CommandState::push_shortcut`] checks those answers still apply and
//! follows the push; anything else takes the full path, which the shortcut leaves exactly as
//! it would have found it (a test runs both on every push of random recordings).
//!
//! Valid only while the state is settled (`dirty` false): every change of what the answers
//! read either marks the state dirty (and settling refreshes the shortcut) or happens on the
//! full push path and in [`CommandState::settle`], which refresh it at their end; the few
//! that do neither ([`CommandState::enter_camera`], [`CommandState::note_push_pusher`]) drop
//! it. A full push that changed the carrier (a new camera) drops it too, and settles do not
//! write it down again until a full push keeps the carrier: the next push is likely another
//! new camera (a projection per draw), for which keeping it would only cost.
//! The command buffer's entry mirrors whether there is one in a flag beside `settle_wanted`
//! (`crate::objects::CommandBufferEntry::push_shortcut`), so a push without one takes no
//! lock for it.

use ash::vk;

use super::CommandState;
use crate::conv::Reversal;
use crate::precise::{Outcome, ShortcutProbe};

/// The answers of [`CommandState::push_constants`] for a settled state (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PushShortcut {
    /// The application's last push layout: pushes with another go the full way.
    layout: vk::PipelineLayout,
    /// The bound pipeline's projection, where its draws would rewrite it, with the outcome the
    /// state settled with; a push writing any of its bytes keeps the state only with that
    /// outcome.
    projection: Option<ShortcutProbe>,
}

impl CommandState {
    /// The shortcut for the state as it is now, if it is settled and a push with its last
    /// layout can leave it so (the module docs); `None` otherwise.
    /// `classified`: the outcome of the projection's current values where the caller just
    /// classified them (found again from the last classification otherwise).
    fn shortcut_now(&self, classified: Option<Outcome>) -> Option<PushShortcut> {
        let layout = self.push.layout();
        if self.dirty || layout == vk::PipelineLayout::null() || !self.push_compatible() {
            return None;
        }
        let precise = self.precise_use().map(|(use_, target)| (*use_, target));
        let position_store = self
            .stage_facts()
            .is_some_and(|p| p.position_store.is_some());
        // What `fold` sends for an outcome: nothing where the carrier held is what it wants.
        let carrier_kept = |outcome: Option<Outcome>| {
            let values = self.carrier_values(outcome).map(f32::to_bits);
            !position_store || self.carrier_held == Some((layout, values))
        };
        // A push missing the projection: `fold` of no outcome (which sends nothing where the
        // draw classifies the projection itself).
        if !(precise.is_some() || carrier_kept(None)) {
            return None;
        }
        let projection = match precise {
            None => None,
            Some((use_, target)) => {
                let outcome = match classified {
                    Some(outcome) => outcome,
                    None => self.push.settled_outcome(&use_, target)?,
                };
                let path = self.pushed_path(&outcome);
                // `learn` of it must change nothing, the path must stay, and the carrier too.
                let learnt = match (outcome, self.reversing.reversal) {
                    (
                        Outcome::Rewritten { near_over_far, .. },
                        Reversal::Infinite { near_over_far: r },
                    ) => self.camera_known && super::same_near_over_far(r, near_over_far),
                    _ => true,
                };
                if !learnt || path != self.path || !carrier_kept(Some(outcome)) {
                    return None;
                }
                Some(self.push.probe(&use_, target, outcome))
            }
        };
        Some(PushShortcut { layout, projection })
    }

    /// Writes down the shortcut where the state may have just settled (the end of a settle,
    /// of the full push path, of a bind that left the state settled); `classified` as for
    /// [`Self::shortcut_now`].
    #[inline]
    pub(super) fn refresh_shortcut(&mut self, classified: Option<Outcome>) {
        self.shortcut = if self.carrier_churn {
            None
        } else {
            self.shortcut_now(classified)
        };
    }

    /// `vkCmdPushConstants` of `data` at `offset` with `layout` and `stages`, where the
    /// shortcut answers for it: the shadow copy follows the push, nothing else changes or is
    /// sent, and the push goes down as the application made it, with the stages returned
    /// ([`Self::push_stages`]). `None`: the push must take [`Self::push_constants`], which
    /// finds the state as it would have without this call (what this did is what the full
    /// path does first, or fills the cache it reads).
    #[inline]
    pub fn push_shortcut(
        &mut self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        data: &[u8],
    ) -> Option<vk::ShaderStageFlags> {
        let shortcut = match &self.shortcut {
            Some(shortcut) if !self.dirty && layout == shortcut.layout => shortcut,
            _ => return None,
        };
        self.push.push(layout, offset, data);
        if let Some(probe) = &shortcut.projection {
            if probe.touched_by(offset, data.len()) && !self.push.keeps(probe) {
                return None;
            }
        }
        self.pushed_since_bind = true;
        Some(self.push_stages(offset, data.len() as u32, stages))
    }

    /// Whether a push may take the shortcut (it has one).
    #[inline]
    pub fn has_push_shortcut(&self) -> bool {
        self.shortcut.is_some()
    }

    /// Drops the shortcut (state it reads changed without marking the state dirty).
    #[inline]
    pub(super) fn drop_shortcut(&mut self) {
        self.shortcut = None;
    }
}
