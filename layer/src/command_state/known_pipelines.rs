//! The pipelines a recording bound, found by handle at its next binds.

use ash::vk;

use super::{PipelineDepth, States};

/// How many pipelines a recording keeps by handle for its binds.
pub(super) const KNOWN_PIPELINES: usize = 4;
// `KnownPipelines::alike` holds a bit per slot.
const _: () = assert!(KNOWN_PIPELINES <= 8);

/// The graphics pipelines a recording bound, with their depth state (`None`: not tracked),
/// found by handle: binding one of them again looks nothing up in the device's table (a shared
/// lock) and takes no reference count. Valid under the device's pipeline generation they were
/// found in (`DeviceObjects::pipeline_generation`): a pipeline destroyed anywhere on the
/// device empties them at the next bind.
#[derive(Clone, Debug, Default)]
pub(super) struct KnownPipelines {
    pub(super) generation: u64,
    pub(super) slots: [(vk::Pipeline, Option<std::sync::Arc<PipelineDepth>>); KNOWN_PIPELINES],
    /// The slot the next pipeline not found replaces.
    pub(super) next: usize,
    /// Which slots settle alike but for value states ([`PipelineDepth::values_apart`]):
    /// bit `j` of `alike[i]`, compared once when either is found, so that a bind between them
    /// compares nothing (bit `i` of `alike[i]`: slot `i` holds a tracked pipeline).
    pub(super) alike: [u8; KNOWN_PIPELINES],
    /// For slots alike: the value states a bind between them evaluates again (`apart[i][j]`,
    /// [`PipelineDepth::values_apart`]).
    pub(super) apart: [[States; KNOWN_PIPELINES]; KNOWN_PIPELINES],
}

impl KnownPipelines {
    /// The slot holding `handle`, found with `lookup` where this recording does not know it.
    pub(super) fn slot(
        &mut self,
        handle: vk::Pipeline,
        generation: u64,
        lookup: impl FnOnce() -> Option<std::sync::Arc<PipelineDepth>>,
    ) -> usize {
        if self.generation != generation {
            *self = KnownPipelines {
                generation,
                ..KnownPipelines::default()
            };
        } else if let Some(index) = self
            .slots
            .iter()
            .position(|(known, _)| *known == handle && handle != vk::Pipeline::null())
        {
            return index;
        }
        self.insert(handle, lookup())
    }

    pub(super) fn insert(
        &mut self,
        handle: vk::Pipeline,
        depth: Option<std::sync::Arc<PipelineDepth>>,
    ) -> usize {
        let index = self.next;
        self.next = (index + 1) % KNOWN_PIPELINES;
        let bit = 1u8 << index;
        let mut alike = 0;
        for (other, (_, known)) in self.slots.iter().enumerate() {
            self.alike[other] &= !bit;
            let apart = match (&depth, known) {
                (Some(depth), Some(known)) if other != index => depth.values_apart(known),
                _ => None,
            };
            if let Some(apart) = apart {
                self.alike[other] |= bit;
                alike |= 1 << other;
                self.apart[other][index] = apart;
                self.apart[index][other] = apart;
            }
        }
        if depth.is_some() {
            alike |= bit;
            self.apart[index][index] = States::NONE;
        }
        self.alike[index] = alike;
        self.slots[index] = (handle, depth);
        index
    }

    /// What binding `slot` after `previous` (both found) needs evaluated again: `Some` of the
    /// value states apart between two tracked pipelines that otherwise settle alike
    /// ([`PipelineDepth::values_apart`]; nothing: no settle); `None`: a full settle.
    pub(super) fn values_apart(&self, previous: usize, slot: usize) -> Option<States> {
        (self.alike[slot] & (1 << previous) != 0).then(|| self.apart[slot][previous])
    }
}
