//! What one command buffer holds for converted copies: its scratch buffers, and the compute
//! state the application bound (bound again after revz's dispatch).
//!
//! Scratch buffers belong to the command buffer that recorded them. They are reused, in
//! order, when it is recorded again (`vkBeginCommandBuffer` needs it not pending, so its last
//! execution is over), and destroyed when it is freed, its pool destroyed or the device
//! destroyed. Each conversion of one recording gets its own buffer, so two conversions never
//! share bytes.

use ash::vk;

use crate::state::DeviceState;

/// One scratch buffer, its memory, and the descriptor set that binds it to the conversion
/// shader (written once: a set in a pool of its own).
#[derive(Debug)]
pub struct Slot {
    pub buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    pool: vk::DescriptorPool,
    pub set: vk::DescriptorSet,
    capacity: u64,
}

/// What one of the application's compute descriptor binds binds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BindKind {
    /// `vkCmdBindDescriptorSets` (or `vkCmdBindDescriptorSets2`): `values` holds the sets'
    /// handles, then the dynamic offsets.
    Sets { dynamic_offsets: u32 },
    /// `vkCmdSetDescriptorBufferOffsetsEXT` (or its `2` form): `values` holds the buffer
    /// indices, then the offsets.
    BufferOffsets,
    /// `vkCmdBindDescriptorBufferEmbeddedSamplersEXT` (or its `2` form): one set, no values.
    EmbeddedSamplers,
}

/// One of the application's compute descriptor binds, as revz replays it on the compute bind
/// point (in the command's first form, whichever form the application called).
#[derive(Clone, Debug, PartialEq, Eq)]
struct ComputeBind {
    kind: BindKind,
    layout: vk::PipelineLayout,
    first: u32,
    /// Sets it binds from `first`.
    count: u32,
    /// The arrays of the call, widened to 64 bits, one after the other ([`BindKind`]).
    values: Vec<u64>,
}

impl ComputeBind {
    fn end(&self) -> u64 {
        u64::from(self.first) + u64::from(self.count)
    }

    /// Whether this bind defines every set `other` defined: `other` no longer shapes the state.
    fn covers(&self, other: &ComputeBind) -> bool {
        self.first <= other.first && other.end() <= self.end()
    }

    /// Whether it sets offsets into the bound descriptor buffers (which binding other buffers
    /// makes invalid).
    fn uses_buffer_bindings(&self) -> bool {
        self.kind == BindKind::BufferOffsets
    }
}

/// The application's compute pipeline and descriptor bindings in one command buffer.
#[derive(Debug, Default)]
pub struct ComputeBindings {
    pipeline: vk::Pipeline,
    /// The binds that still define some set, in the order they were made: replaying them
    /// rebuilds the same state, disturbances included.
    binds: Vec<ComputeBind>,
    /// Compute descriptors were bound a way revz cannot replay (push descriptors, a bind
    /// without a layout handle or with a `pNext` chain, a compute shader object): revz cannot
    /// restore them.
    unrestorable: bool,
}

/// Binds kept before the command buffer's compute state counts as unrestorable (an
/// application binding many disjoint set ranges without ever covering the earlier ones).
const MAX_BINDS: usize = 16;

impl ComputeBindings {
    pub fn bind_pipeline(&mut self, pipeline: vk::Pipeline) {
        self.pipeline = pipeline;
    }

    /// `vkCmdBindDescriptorSets` of the compute bind point.
    pub fn bind_sets(
        &mut self,
        layout: vk::PipelineLayout,
        first: u32,
        sets: &[vk::DescriptorSet],
        dynamic_offsets: &[u32],
    ) {
        let kind = BindKind::Sets {
            dynamic_offsets: dynamic_offsets.len() as u32,
        };
        let values = sets
            .iter()
            .map(|&set| vk::Handle::as_raw(set))
            .chain(dynamic_offsets.iter().map(|&o| u64::from(o)));
        self.push(kind, layout, (first, sets.len() as u32), values);
    }

    /// `vkCmdSetDescriptorBufferOffsetsEXT` of the compute bind point: sets `first..` take
    /// `offsets` into the descriptor buffers bound at `indices`.
    pub fn set_buffer_offsets(
        &mut self,
        layout: vk::PipelineLayout,
        first: u32,
        indices: &[u32],
        offsets: &[vk::DeviceSize],
    ) {
        if indices.len() != offsets.len() {
            self.bound_otherwise();
            return;
        }
        let values = indices
            .iter()
            .map(|&i| u64::from(i))
            .chain(offsets.iter().copied());
        let count = indices.len() as u32;
        self.push(BindKind::BufferOffsets, layout, (first, count), values);
    }

    /// `vkCmdBindDescriptorBufferEmbeddedSamplersEXT` of the compute bind point.
    pub fn bind_embedded_samplers(&mut self, layout: vk::PipelineLayout, set: u32) {
        let none = std::iter::empty();
        self.push(BindKind::EmbeddedSamplers, layout, (set, 1), none);
    }

    /// `vkCmdBindDescriptorBuffersEXT`: the offsets set into the buffers bound before are no
    /// longer valid (the spec), so they are not replayed.
    pub fn bind_descriptor_buffers(&mut self) {
        self.binds.retain(|bind| !bind.uses_buffer_bindings());
    }

    /// Keeps a bind of `count` sets from `first`, dropping the earlier binds it covers. The
    /// storage of one of those is reused: an application that binds the same sets at every
    /// dispatch allocates nothing here after its first.
    fn push(
        &mut self,
        kind: BindKind,
        layout: vk::PipelineLayout,
        (first, count): (u32, u32),
        values: impl Iterator<Item = u64>,
    ) {
        let mut bind = ComputeBind {
            kind,
            layout,
            first,
            count,
            values: Vec::new(),
        };
        let mut index = 0;
        while index < self.binds.len() {
            if bind.covers(&self.binds[index]) {
                let earlier = self.binds.remove(index);
                if bind.values.capacity() == 0 {
                    bind.values = earlier.values;
                }
            } else {
                index += 1;
            }
        }
        bind.values.clear();
        bind.values.extend(values);
        self.binds.push(bind);
        if self.binds.len() > MAX_BINDS {
            self.binds.clear();
            self.unrestorable = true;
        }
    }

    /// Compute descriptors were bound in a way revz does not follow.
    pub fn bound_otherwise(&mut self) {
        self.unrestorable = true;
    }

    pub fn restorable(&self) -> bool {
        !self.unrestorable
    }

    /// Binds the application's compute state again (after revz's dispatch).
    ///
    /// # Safety
    /// `buffer` must be recording, on `device`.
    pub unsafe fn restore(&self, device: &DeviceState, buffer: vk::CommandBuffer) {
        let v = device.next.fp_v1_0();
        let compute = vk::PipelineBindPoint::COMPUTE;
        if self.pipeline != vk::Pipeline::null() {
            // SAFETY: the application's pipeline, bound by it in this command buffer.
            unsafe { (v.cmd_bind_pipeline)(buffer, compute, self.pipeline) };
        }
        for bind in &self.binds {
            let (layout, first, count) = (bind.layout, bind.first, bind.count as usize);
            let (head, tail) = bind.values.split_at(count.min(bind.values.len()));
            match bind.kind {
                BindKind::Sets { .. } => {
                    let sets: Vec<vk::DescriptorSet> =
                        head.iter().map(|&raw| vk::Handle::from_raw(raw)).collect();
                    let offsets: Vec<u32> = tail.iter().map(|&o| o as u32).collect();
                    // SAFETY: the application's own bind, replayed in order.
                    unsafe {
                        (v.cmd_bind_descriptor_sets)(
                            buffer,
                            compute,
                            layout,
                            first,
                            sets.len() as u32,
                            sets.as_ptr(),
                            offsets.len() as u32,
                            offsets.as_ptr(),
                        )
                    };
                }
                BindKind::BufferOffsets => {
                    let indices: Vec<u32> = head.iter().map(|&i| i as u32).collect();
                    if let Some(set_offsets) = device.commands.set_descriptor_buffer_offsets {
                        // SAFETY: the application's own offsets, into the descriptor buffers
                        // it bound (revz binds none), replayed in order.
                        unsafe {
                            set_offsets(
                                buffer,
                                compute,
                                layout,
                                first,
                                indices.len() as u32,
                                indices.as_ptr(),
                                tail.as_ptr(),
                            )
                        };
                    }
                }
                BindKind::EmbeddedSamplers => {
                    if let Some(bind_samplers) = device.commands.bind_embedded_samplers {
                        // SAFETY: the application's own bind, replayed in order.
                        unsafe { bind_samplers(buffer, compute, layout, first) };
                    }
                }
            }
        }
    }
}

/// A command buffer's scratch buffers and compute state.
#[derive(Debug, Default)]
pub struct CommandCopies {
    slots: Vec<Slot>,
    /// Slots used by the current recording.
    used: usize,
    /// Images converted blits read from, made by the current recording.
    staged: Vec<(vk::Image, vk::DeviceMemory)>,
    pub compute: ComputeBindings,
    /// Conditional rendering is active (begun here, or inherited by a secondary): it could
    /// discard revz's dispatch while the copies around it run.
    pub conditional: bool,
    /// What this recording refreshed of read twins and has not written since: later
    /// refreshes skip it.
    pub ledger: crate::policy::twins::RefreshLedger,
}

impl CommandCopies {
    /// A new recording begins: every slot is free again, the last recording's staged images
    /// are destroyed (it is not pending: `vkBeginCommandBuffer` needs that), and no compute
    /// state is bound.
    pub fn begin(&mut self, device: &DeviceState) {
        self.destroy_staged(device);
        self.reset_recording();
    }

    fn reset_recording(&mut self) {
        self.used = 0;
        self.compute = ComputeBindings::default();
        self.conditional = false;
        self.ledger.forget();
    }

    fn destroy_staged(&mut self, device: &DeviceState) {
        let v = device.next.fp_v1_0();
        for (image, memory) in self.staged.drain(..) {
            // SAFETY: revz's own image, not used by a pending command buffer.
            unsafe {
                (v.destroy_image)(device.handle, image, std::ptr::null());
                (v.free_memory)(device.handle, memory, std::ptr::null());
            }
        }
    }

    /// A device-local image of `image_type` (2D, or 3D for a 3D source's deep boxes),
    /// `format`, `extent` and `layers` for a converted blit to read from (TRANSFER_SRC |
    /// TRANSFER_DST), kept until the command buffer is recorded again.
    pub fn staged_image(
        &mut self,
        device: &DeviceState,
        (image_type, format): (vk::ImageType, vk::Format),
        extent: vk::Extent3D,
        layers: u32,
    ) -> Option<vk::Image> {
        let v = device.next.fp_v1_0();
        let null = std::ptr::null();
        let info = vk::ImageCreateInfo::default()
            .image_type(image_type)
            .format(format)
            .extent(extent)
            .mip_levels(1)
            .array_layers(layers)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let mut image = vk::Image::null();
        let mut memory = vk::DeviceMemory::null();
        let made = (|| {
            // SAFETY: valid create infos and outputs on a live device.
            unsafe { (v.create_image)(device.handle, &info, null, &mut image) }.result()?;
            let mut requirements = vk::MemoryRequirements::default();
            // SAFETY: as above.
            unsafe { (v.get_image_memory_requirements)(device.handle, image, &mut requirements) };
            // SAFETY: as above.
            memory = unsafe { allocate(device, requirements) }?;
            // SAFETY: as above.
            unsafe { (v.bind_image_memory)(device.handle, image, memory, 0) }.result()
        })();
        self.staged.push((image, memory));
        match made {
            Ok(()) => Some(image),
            Err(result) => {
                log::debug!("cannot create an image for a converted depth blit: {result:?}");
                None
            }
        }
    }

    /// The next free slot with room for `size` bytes, made or grown as needed.
    pub fn slot(&mut self, device: &DeviceState, size: u64) -> Option<&Slot> {
        let index = self.used;
        match self.slots.get(index).map(|slot| slot.capacity >= size) {
            Some(true) => {}
            Some(false) => {
                // SAFETY: a live device.
                let grown = unsafe { create_slot(device, size)? };
                let small = std::mem::replace(&mut self.slots[index], grown);
                // SAFETY: the slot is not in use: an earlier, finished recording used it.
                unsafe { destroy_slot(device, &small) };
            }
            // `used` never passes the slots' count: this is the next one.
            None => {
                // SAFETY: a live device.
                let slot = unsafe { create_slot(device, size)? };
                self.slots.push(slot);
            }
        }
        self.used += 1;
        self.slots.get(index)
    }

    /// Destroys every slot (the command buffer is freed, or its device destroyed).
    pub fn destroy(&mut self, device: &DeviceState) {
        self.destroy_staged(device);
        for slot in self.slots.drain(..) {
            // SAFETY: the command buffer is not pending (the application's contract for
            // freeing it and for destroying the device).
            unsafe { destroy_slot(device, &slot) };
        }
        self.used = 0;
    }
}

/// Scratch buffers are made at least this large, so that small copies share one size.
const MIN_CAPACITY: u64 = 64 * 1024;

/// Creates a scratch buffer of at least `size` bytes with its memory and descriptor set.
///
/// # Safety
/// `device` must be live.
unsafe fn create_slot(device: &DeviceState, size: u64) -> Option<Slot> {
    let v = device.next.fp_v1_0();
    let handle = device.handle;
    let null = std::ptr::null();
    let capacity = size.max(MIN_CAPACITY).checked_next_power_of_two()?;
    let capacity = if device.copies.fits(capacity) {
        capacity
    } else {
        size
    };
    let mut slot = Slot {
        buffer: vk::Buffer::null(),
        memory: vk::DeviceMemory::null(),
        pool: vk::DescriptorPool::null(),
        set: vk::DescriptorSet::null(),
        capacity,
    };
    let made = (|| {
        let info = vk::BufferCreateInfo::default()
            .size(capacity)
            .usage(
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::TRANSFER_DST,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create infos and outputs (here and below), on a live device.
        unsafe { (v.create_buffer)(handle, &info, null, &mut slot.buffer) }.result()?;
        let mut requirements = vk::MemoryRequirements::default();
        // SAFETY: as above.
        unsafe { (v.get_buffer_memory_requirements)(handle, slot.buffer, &mut requirements) };
        // SAFETY: as above.
        slot.memory = unsafe { allocate(device, requirements) }?;
        // SAFETY: as above.
        unsafe { (v.bind_buffer_memory)(handle, slot.buffer, slot.memory, 0) }.result()?;
        let sizes = [vk::DescriptorPoolSize {
            ty: vk::DescriptorType::STORAGE_BUFFER,
            descriptor_count: 1,
        }];
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: as above.
        unsafe { (v.create_descriptor_pool)(handle, &pool_info, null, &mut slot.pool) }.result()?;
        let pipeline = device
            .copies
            .layouts(handle, &device.next)
            .ok_or(vk::Result::ERROR_INITIALIZATION_FAILED)?;
        let layouts = [pipeline.set_layout];
        let set_info = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(slot.pool)
            .set_layouts(&layouts);
        // SAFETY: as above.
        unsafe { (v.allocate_descriptor_sets)(handle, &set_info, &mut slot.set) }.result()?;
        let buffer_info = [vk::DescriptorBufferInfo {
            buffer: slot.buffer,
            offset: 0,
            range: vk::WHOLE_SIZE,
        }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(slot.set)
            .dst_binding(0)
            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
            .buffer_info(&buffer_info);
        // SAFETY: a set just allocated, not in use.
        unsafe { (v.update_descriptor_sets)(handle, 1, &write, 0, std::ptr::null()) };
        Ok::<(), vk::Result>(())
    })();
    match made {
        Ok(()) => Some(slot),
        Err(result) => {
            // Logged at debug: the copy's warning (once per reason) says it went unconverted.
            log::debug!(
                "cannot create a {capacity}-byte scratch buffer for a depth copy: {result:?}"
            );
            // SAFETY: what was made of the slot, unused.
            unsafe { destroy_slot(device, &slot) };
            None
        }
    }
}

/// Device memory for `requirements`, device-local where a type allows it (scratch buffers and
/// staged images alike).
///
/// # Safety
/// `device` must be live.
pub(crate) unsafe fn allocate(
    device: &DeviceState,
    requirements: vk::MemoryRequirements,
) -> Result<vk::DeviceMemory, vk::Result> {
    let memory_type = device
        .copies
        .memory_type(requirements.memory_type_bits)
        .ok_or(vk::Result::ERROR_OUT_OF_DEVICE_MEMORY)?;
    let info = vk::MemoryAllocateInfo::default()
        .allocation_size(requirements.size)
        .memory_type_index(memory_type);
    let mut memory = vk::DeviceMemory::null();
    // SAFETY: a valid allocate info and output on a live device (the caller's contract).
    unsafe {
        (device.next.fp_v1_0().allocate_memory)(device.handle, &info, std::ptr::null(), &mut memory)
    }
    .result()?;
    Ok(memory)
}

/// # Safety
/// The slot must be revz's and not in use by a pending command buffer.
unsafe fn destroy_slot(device: &DeviceState, slot: &Slot) {
    let v = device.next.fp_v1_0();
    let null = std::ptr::null();
    // SAFETY: the caller's contract; null handles are ignored.
    unsafe {
        (v.destroy_descriptor_pool)(device.handle, slot.pool, null);
        (v.destroy_buffer)(device.handle, slot.buffer, null);
        (v.free_memory)(device.handle, slot.memory, null);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ash::vk::Handle;

    fn sets(raw: &[u64]) -> Vec<vk::DescriptorSet> {
        raw.iter()
            .map(|&r| vk::DescriptorSet::from_raw(r))
            .collect()
    }

    #[test]
    fn binds_covered_by_a_later_one_are_dropped() {
        let layout = vk::PipelineLayout::from_raw(9);
        let mut compute = ComputeBindings::default();
        compute.bind_sets(layout, 0, &sets(&[1, 2]), &[]);
        compute.bind_sets(layout, 1, &sets(&[3]), &[16]);
        assert_eq!(
            compute.binds.len(),
            2,
            "set 0 of the first bind still stands"
        );
        compute.bind_sets(layout, 0, &sets(&[4, 5]), &[]);
        assert_eq!(compute.binds.len(), 1);
        assert_eq!(compute.binds[0].values, [4, 5]);
        assert!(compute.restorable());
    }

    #[test]
    fn descriptor_buffer_offsets_and_embedded_samplers_are_kept_beside_sets_in_order() {
        let layout = vk::PipelineLayout::from_raw(9);
        let mut compute = ComputeBindings::default();
        compute.bind_sets(layout, 0, &sets(&[1]), &[32]);
        compute.set_buffer_offsets(layout, 1, &[0, 1], &[256, 512]);
        compute.bind_embedded_samplers(layout, 3);
        let kinds: Vec<BindKind> = compute.binds.iter().map(|b| b.kind).collect();
        assert_eq!(
            kinds,
            [
                BindKind::Sets { dynamic_offsets: 1 },
                BindKind::BufferOffsets,
                BindKind::EmbeddedSamplers
            ]
        );
        assert_eq!(compute.binds[0].values, [1, 32]);
        assert_eq!(compute.binds[1].values, [0, 1, 256, 512]);
        assert_eq!((compute.binds[2].first, compute.binds[2].count), (3, 1));
        // Offsets over sets 0 to 2 replace the sets bound at 0 and the offsets at 1..3.
        compute.set_buffer_offsets(layout, 0, &[0, 0, 0], &[0, 64, 128]);
        let kept: Vec<(BindKind, u32)> = compute.binds.iter().map(|b| (b.kind, b.first)).collect();
        assert_eq!(
            kept,
            [
                (BindKind::EmbeddedSamplers, 3),
                (BindKind::BufferOffsets, 0)
            ]
        );
        assert!(compute.restorable());
    }

    #[test]
    fn binding_descriptor_buffers_drops_the_offsets_into_the_earlier_ones() {
        let layout = vk::PipelineLayout::from_raw(9);
        let mut compute = ComputeBindings::default();
        compute.set_buffer_offsets(layout, 0, &[0], &[64]);
        compute.bind_embedded_samplers(layout, 1);
        compute.bind_sets(layout, 2, &sets(&[7]), &[]);
        compute.bind_descriptor_buffers();
        let kinds: Vec<BindKind> = compute.binds.iter().map(|b| b.kind).collect();
        assert_eq!(
            kinds,
            [
                BindKind::EmbeddedSamplers,
                BindKind::Sets { dynamic_offsets: 0 }
            ]
        );
        assert!(compute.restorable());
    }

    #[test]
    fn a_bind_that_covers_an_earlier_one_reuses_its_storage() {
        let layout = vk::PipelineLayout::from_raw(9);
        let mut compute = ComputeBindings::default();
        compute.set_buffer_offsets(layout, 0, &[0, 1], &[64, 128]);
        let storage = compute.binds[0].values.as_ptr();
        compute.set_buffer_offsets(layout, 0, &[1, 0], &[0, 32]);
        assert_eq!(compute.binds.len(), 1);
        assert_eq!(compute.binds[0].values, [1, 0, 0, 32]);
        assert_eq!(compute.binds[0].values.as_ptr(), storage, "reallocated");
    }

    #[test]
    fn offsets_whose_arrays_differ_in_length_are_not_restorable() {
        let layout = vk::PipelineLayout::from_raw(9);
        let mut compute = ComputeBindings::default();
        compute.set_buffer_offsets(layout, 0, &[0, 1], &[64]);
        assert!(!compute.restorable());
    }

    #[test]
    fn too_many_disjoint_binds_or_other_bindings_are_not_restorable() {
        let layout = vk::PipelineLayout::from_raw(9);
        let mut compute = ComputeBindings::default();
        for set in 0..=MAX_BINDS as u32 {
            compute.bind_sets(layout, set, &sets(&[1]), &[]);
        }
        assert!(!compute.restorable());
        let mut other = ComputeBindings::default();
        other.bound_otherwise();
        assert!(!other.restorable());
        let mut copies = CommandCopies {
            compute: other,
            ..Default::default()
        };
        copies.reset_recording();
        assert!(
            copies.compute.restorable(),
            "a new recording binds nothing yet"
        );
    }
}
