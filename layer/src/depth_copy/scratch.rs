//! What one command buffer holds for converted copies: its scratch buffers, and the compute
//! state the application bound (bound again after revz's dispatch: `super::compute_bindings`).
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

/// A command buffer's scratch buffers and compute state.
#[derive(Debug, Default)]
pub struct CommandCopies {
    slots: Vec<Slot>,
    /// Slots used by the current recording.
    used: usize,
    /// Images converted blits read from, made by the current recording.
    staged: Vec<(vk::Image, vk::DeviceMemory)>,
    pub compute: super::compute_bindings::ComputeBindings,
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
        self.compute = Default::default();
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

    #[test]
    fn a_new_recording_binds_no_compute_state_yet() {
        let mut copies = CommandCopies::default();
        copies.compute.bound_otherwise();
        assert!(!copies.compute.restorable());
        copies.reset_recording();
        assert!(
            copies.compute.restorable(),
            "a new recording binds nothing yet"
        );
    }
}
