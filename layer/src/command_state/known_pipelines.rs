//! The pipelines a recording bound, found by handle at its next binds.

use ash::vk;

use super::PipelineDepth;

/// How many pipelines a recording keeps by handle for its binds.
pub(super) const KNOWN_PIPELINES: usize = 4;

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
        self.slots[index] = (handle, depth);
        index
    }
}
