//! The compute state the application bound in one command buffer, kept so that revz can bind
//! it again after the dispatch of a conversion (`super::record`, `super::twin`): the compute
//! pipeline, and every command that binds compute descriptors, replayed in the order the
//! application made them (those a later one replaces dropped).
//!
//! Followed: descriptor set binds, descriptor buffer offsets and embedded samplers
//! (`VK_EXT_descriptor_buffer`), push descriptors (writes, and template pushes turned into
//! writes at record time, so that no template handle is kept), and a compute shader object
//! bound in the pipeline's place. Refused (the state counts as unrestorable, and later
//! conversions of the recording go down unconverted, logged): binds whose layout is given in a
//! `pNext` chain, pushed writes of types revz does not copy (acceleration structures, mutable
//! descriptors), with an extension structure other than an inline uniform block's or with a
//! null array their type names, and more than [`MAX_BINDS`] binds that do not replace each
//! other.

use ash::vk;

use crate::state::DeviceState;

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
    /// A push of descriptors into one set (`vkCmdPushDescriptorSet` and its other forms, a
    /// template's included): `writes` holds them.
    Pushed,
}

/// One of the application's compute descriptor binds, as revz replays it on the compute bind
/// point (in the command's first form, whichever form the application called).
#[derive(Clone, Debug)]
struct ComputeBind {
    kind: BindKind,
    layout: vk::PipelineLayout,
    first: u32,
    /// Sets it binds from `first`.
    count: u32,
    /// The arrays of the call, widened to 64 bits, one after the other ([`BindKind`]).
    values: Vec<u64>,
    /// The writes of a push ([`BindKind::Pushed`]).
    writes: Vec<PushedWrite>,
}

impl ComputeBind {
    fn end(&self) -> u64 {
        u64::from(self.first) + u64::from(self.count)
    }

    /// Whether this bind leaves nothing of what `earlier` set: it binds every set `earlier`
    /// bound; or, both pushes into one set (which update it incrementally), it writes every
    /// descriptor `earlier` wrote.
    fn replaces(&self, earlier: &ComputeBind) -> bool {
        if earlier.kind == BindKind::Pushed && self.kind == BindKind::Pushed {
            return self.first == earlier.first
                && earlier
                    .writes
                    .iter()
                    .all(|old| self.writes.iter().any(|new| new.covers(old)));
        }
        self.first <= earlier.first && earlier.end() <= self.end()
    }

    /// Whether it sets offsets into the bound descriptor buffers (which binding other buffers
    /// makes invalid).
    fn uses_buffer_bindings(&self) -> bool {
        self.kind == BindKind::BufferOffsets
    }
}

/// One pushed `VkWriteDescriptorSet`, its arrays copied.
#[derive(Clone, Debug, Default)]
pub struct PushedWrite {
    binding: u32,
    array_element: u32,
    /// Descriptors written (bytes, for an inline uniform block).
    count: u32,
    ty: vk::DescriptorType,
    images: Vec<vk::DescriptorImageInfo>,
    buffers: Vec<vk::DescriptorBufferInfo>,
    texel_views: Vec<vk::BufferView>,
    /// An inline uniform block's bytes.
    inline: Vec<u8>,
}

/// How a descriptor type's data is given.
enum Payload {
    Images,
    Buffers,
    TexelViews,
    Inline,
}

fn payload(ty: vk::DescriptorType) -> Option<Payload> {
    match ty {
        vk::DescriptorType::SAMPLER
        | vk::DescriptorType::COMBINED_IMAGE_SAMPLER
        | vk::DescriptorType::SAMPLED_IMAGE
        | vk::DescriptorType::STORAGE_IMAGE
        | vk::DescriptorType::INPUT_ATTACHMENT => Some(Payload::Images),
        vk::DescriptorType::UNIFORM_BUFFER
        | vk::DescriptorType::STORAGE_BUFFER
        | vk::DescriptorType::UNIFORM_BUFFER_DYNAMIC
        | vk::DescriptorType::STORAGE_BUFFER_DYNAMIC => Some(Payload::Buffers),
        vk::DescriptorType::UNIFORM_TEXEL_BUFFER | vk::DescriptorType::STORAGE_TEXEL_BUFFER => {
            Some(Payload::TexelViews)
        }
        vk::DescriptorType::INLINE_UNIFORM_BLOCK => Some(Payload::Inline),
        _ => None,
    }
}

impl PushedWrite {
    /// Whether this write sets every descriptor `other` sets (the same binding and type, its
    /// range of elements inside this one's; a write that runs on into the next binding is
    /// compared by its first binding only, which keeps more than needed, never less).
    fn covers(&self, other: &PushedWrite) -> bool {
        let end = |w: &PushedWrite| u64::from(w.array_element) + u64::from(w.count);
        self.binding == other.binding
            && self.ty == other.ty
            && self.array_element <= other.array_element
            && end(other) <= end(self)
    }

    /// Names the descriptors this write sets, its arrays emptied (their storage kept).
    fn reset(&mut self, (binding, array_element): (u32, u32), count: u32, ty: vk::DescriptorType) {
        self.binding = binding;
        self.array_element = array_element;
        self.count = count;
        self.ty = ty;
        self.images.clear();
        self.buffers.clear();
        self.texel_views.clear();
        self.inline.clear();
    }

    /// Copies `write` into this one (reusing its arrays); `false` where revz cannot copy it: a
    /// type it does not know, an extension structure other than an inline uniform block's, or
    /// a null array its type names.
    ///
    /// # Safety
    /// `write` is a valid write (the application's, or revz's patched copy of one).
    pub unsafe fn assign(&mut self, write: &vk::WriteDescriptorSet<'_>) -> bool {
        let Some(payload) = payload(write.descriptor_type) else {
            return false;
        };
        let inline_block = matches!(payload, Payload::Inline);
        if !write.p_next.is_null() && !inline_block {
            return false;
        }
        let count = write.descriptor_count;
        self.reset(
            (write.dst_binding, write.dst_array_element),
            count,
            write.descriptor_type,
        );
        // An array the type names left null (where the spec lets the driver ignore it, as for
        // immutable samplers): replaying the write would hand the driver no array at all.
        let array_missing = match payload {
            Payload::Images => write.p_image_info.is_null(),
            Payload::Buffers => write.p_buffer_info.is_null(),
            Payload::TexelViews => write.p_texel_buffer_view.is_null(),
            Payload::Inline => false,
        };
        if array_missing && count > 0 {
            return false;
        }
        // SAFETY: the arrays the type names hold `count` elements (the caller's contract).
        unsafe {
            match payload {
                Payload::Images => self
                    .images
                    .extend_from_slice(slice(write.p_image_info, count)),
                Payload::Buffers => self
                    .buffers
                    .extend_from_slice(slice(write.p_buffer_info, count)),
                Payload::TexelViews => self
                    .texel_views
                    .extend_from_slice(slice(write.p_texel_buffer_view, count)),
                Payload::Inline => {
                    // The data is in the chained VkWriteDescriptorSetInlineUniformBlock.
                    let block = write
                        .p_next
                        .cast::<vk::WriteDescriptorSetInlineUniformBlock<'_>>();
                    let Some(block) = block.as_ref() else {
                        return false;
                    };
                    if block.s_type != vk::StructureType::WRITE_DESCRIPTOR_SET_INLINE_UNIFORM_BLOCK
                        || !block.p_next.is_null()
                    {
                        return false;
                    }
                    self.inline
                        .extend_from_slice(slice(block.p_data.cast::<u8>(), block.data_size));
                }
            }
        }
        true
    }

    /// Copies a descriptor update template's entry, read from `data` (at its offset and
    /// stride), into this one; `false` where revz cannot copy it (as [`Self::assign`]).
    ///
    /// # Safety
    /// `data` is valid data for a template with this entry.
    pub unsafe fn assign_entry(
        &mut self,
        entry: &vk::DescriptorUpdateTemplateEntry,
        data: *const u8,
    ) -> bool {
        let Some(payload) = payload(entry.descriptor_type) else {
            return false;
        };
        let count = entry.descriptor_count;
        self.reset(
            (entry.dst_binding, entry.dst_array_element),
            count,
            entry.descriptor_type,
        );
        // Element `i` of the entry: read unaligned, as the application may lay out its data
        // at any offset.
        // SAFETY: the template reads these bytes of `data` (the caller's contract).
        let at = |i: u32| unsafe { data.add(entry.offset + entry.stride * i as usize) };
        // SAFETY: as above.
        unsafe {
            match payload {
                Payload::Images => self.images.extend(
                    (0..count).map(|i| at(i).cast::<vk::DescriptorImageInfo>().read_unaligned()),
                ),
                Payload::Buffers => self.buffers.extend(
                    (0..count).map(|i| at(i).cast::<vk::DescriptorBufferInfo>().read_unaligned()),
                ),
                Payload::TexelViews => self
                    .texel_views
                    .extend((0..count).map(|i| at(i).cast::<vk::BufferView>().read_unaligned())),
                // `descriptorCount` bytes at the entry's offset.
                Payload::Inline => self.inline.extend_from_slice(slice(at(0), count)),
            }
        }
        true
    }
}

/// The `count` elements at `ptr` (none where it is null).
///
/// # Safety
/// A non-null `ptr` points at `count` valid elements.
unsafe fn slice<'a, T>(ptr: *const T, count: u32) -> &'a [T] {
    if ptr.is_null() || count == 0 {
        &[]
    } else {
        // SAFETY: the caller's contract.
        unsafe { std::slice::from_raw_parts(ptr, count as usize) }
    }
}

/// What the application bound last to run compute work: a pipeline or a shader object
/// (binding either unbinds the other).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum ComputeProgram {
    #[default]
    None,
    Pipeline(vk::Pipeline),
    /// A compute shader object (`vkCmdBindShadersEXT`; null: the stage unbound).
    Shader(vk::ShaderEXT),
}

/// The application's compute pipeline and descriptor bindings in one command buffer.
#[derive(Debug, Default)]
pub struct ComputeBindings {
    program: ComputeProgram,
    /// The binds that still define some descriptor, in the order they were made: replaying
    /// them rebuilds the same state, disturbances included.
    binds: Vec<ComputeBind>,
    /// Compute descriptors were bound a way revz cannot replay (module docs).
    unrestorable: bool,
}

/// Binds kept before the command buffer's compute state counts as unrestorable (an
/// application binding many disjoint set ranges, or pushing disjoint parts of a set, without
/// ever replacing the earlier ones).
const MAX_BINDS: usize = 16;

impl ComputeBindings {
    pub fn bind_pipeline(&mut self, pipeline: vk::Pipeline) {
        self.program = ComputeProgram::Pipeline(pipeline);
    }

    /// `vkCmdBindShadersEXT` naming the compute stage (`shader` null: unbound).
    pub fn bind_shader(&mut self, shader: vk::ShaderEXT) {
        self.program = ComputeProgram::Shader(shader);
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
        let bind = self.take_storage(kind, layout, (first, sets.len() as u32));
        self.keep(bind, |bind| {
            bind.values.extend(values);
            true
        });
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
        let bind = self.take_storage(BindKind::BufferOffsets, layout, (first, count));
        self.keep(bind, |bind| {
            bind.values.extend(values);
            true
        });
    }

    /// `vkCmdBindDescriptorBufferEmbeddedSamplersEXT` of the compute bind point.
    pub fn bind_embedded_samplers(&mut self, layout: vk::PipelineLayout, set: u32) {
        let bind = self.take_storage(BindKind::EmbeddedSamplers, layout, (set, 1));
        self.keep(bind, |_| true);
    }

    /// A push of `writes` into compute set `set` (`vkCmdPushDescriptorSet` and its `2`
    /// form): kept as copies, or the state counts as unrestorable where one cannot be copied
    /// ([`PushedWrite::assign`]).
    ///
    /// # Safety
    /// `writes` are valid writes (the application's, or revz's patched copies of them).
    pub unsafe fn push_writes(
        &mut self,
        layout: vk::PipelineLayout,
        set: u32,
        writes: &[vk::WriteDescriptorSet<'_>],
    ) {
        // SAFETY: the caller's contract.
        self.push_with(layout, set, writes.len(), |copy, i| unsafe {
            copy.assign(&writes[i])
        });
    }

    /// A template push into compute set `set` (`vkCmdPushDescriptorSetWithTemplate` and its
    /// `2` form), its `entries` read from `data` into writes now (the template may be gone
    /// before revz replays them).
    ///
    /// # Safety
    /// `data` is valid data for a template of `entries`.
    pub unsafe fn push_template(
        &mut self,
        layout: vk::PipelineLayout,
        set: u32,
        entries: &[vk::DescriptorUpdateTemplateEntry],
        data: *const u8,
    ) {
        if data.is_null() {
            self.bound_otherwise();
            return;
        }
        // SAFETY: the caller's contract.
        self.push_with(layout, set, entries.len(), |copy, i| unsafe {
            copy.assign_entry(&entries[i], data)
        });
    }

    fn push_with(
        &mut self,
        layout: vk::PipelineLayout,
        set: u32,
        count: usize,
        mut assign: impl FnMut(&mut PushedWrite, usize) -> bool,
    ) {
        // The writes are copied before the binds this one replaces are found (that needs
        // them), into a storage of its own: no earlier push's can be reused here.
        let mut writes = vec![PushedWrite::default(); count];
        if !writes.iter_mut().enumerate().all(|(i, w)| assign(w, i)) {
            self.bound_otherwise();
            return;
        }
        let bind = ComputeBind {
            kind: BindKind::Pushed,
            layout,
            first: set,
            count: 1,
            values: Vec::new(),
            writes,
        };
        self.binds.retain(|earlier| !bind.replaces(earlier));
        self.push_bind(bind);
    }

    /// A bind of `count` sets from `first` with the storage of one of the earlier binds it
    /// replaces (cleared), where there is one: an application that binds the same sets at
    /// every dispatch allocates nothing here after its first. Those binds are dropped.
    fn take_storage(
        &mut self,
        kind: BindKind,
        layout: vk::PipelineLayout,
        (first, count): (u32, u32),
    ) -> ComputeBind {
        let mut bind = ComputeBind {
            kind,
            layout,
            first,
            count,
            values: Vec::new(),
            writes: Vec::new(),
        };
        let mut index = 0;
        while index < self.binds.len() {
            if bind.replaces(&self.binds[index]) {
                let earlier = self.binds.remove(index);
                if bind.values.capacity() == 0 {
                    bind.values = earlier.values;
                    bind.values.clear();
                }
            } else {
                index += 1;
            }
        }
        bind
    }

    /// Fills `bind` and keeps it, or counts the state unrestorable where `fill` fails.
    fn keep(&mut self, mut bind: ComputeBind, fill: impl FnOnce(&mut ComputeBind) -> bool) {
        if fill(&mut bind) {
            self.push_bind(bind);
        } else {
            self.bound_otherwise();
        }
    }

    fn push_bind(&mut self, bind: ComputeBind) {
        self.binds.push(bind);
        if self.binds.len() > MAX_BINDS {
            self.binds.clear();
            self.unrestorable = true;
        }
    }

    /// `vkCmdBindDescriptorBuffersEXT`: the offsets set into the buffers bound before are no
    /// longer valid (the spec), so they are not replayed.
    pub fn bind_descriptor_buffers(&mut self) {
        self.binds.retain(|bind| !bind.uses_buffer_bindings());
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
        match self.program {
            ComputeProgram::None => {}
            // SAFETY: the application's pipeline, bound by it in this command buffer.
            ComputeProgram::Pipeline(pipeline) => unsafe {
                (v.cmd_bind_pipeline)(buffer, compute, pipeline)
            },
            ComputeProgram::Shader(shader) => {
                if let Some(bind_shaders) = device.commands.bind_shaders_ext {
                    let stage = vk::ShaderStageFlags::COMPUTE;
                    // SAFETY: the application's compute shader object (or none), bound by it
                    // in this command buffer.
                    unsafe { bind_shaders(buffer, 1, &stage, &shader) };
                }
            }
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
                BindKind::Pushed => {
                    if let Some(push) = device.commands.push_descriptor_set {
                        // SAFETY: copies of the application's own writes (views of images with
                        // a twin already the twins'), replayed in order.
                        unsafe { replay_push(push, buffer, layout, first, &bind.writes) };
                    }
                }
            }
        }
    }
}

/// Pushes `writes` again into compute set `set` of `layout`.
///
/// # Safety
/// `buffer` is recording; the writes are copies of valid ones for that set.
unsafe fn replay_push(
    push: vk::PFN_vkCmdPushDescriptorSetKHR,
    buffer: vk::CommandBuffer,
    layout: vk::PipelineLayout,
    set: u32,
    writes: &[PushedWrite],
) {
    // The inline uniform blocks' structures first, so that the writes can point at them.
    let blocks: Vec<vk::WriteDescriptorSetInlineUniformBlock<'_>> = writes
        .iter()
        .map(|w| vk::WriteDescriptorSetInlineUniformBlock::default().data(&w.inline))
        .collect();
    let sent: Vec<vk::WriteDescriptorSet<'_>> = writes
        .iter()
        .zip(&blocks)
        .map(|(w, block)| {
            let mut write = vk::WriteDescriptorSet {
                dst_binding: w.binding,
                dst_array_element: w.array_element,
                descriptor_count: w.count,
                descriptor_type: w.ty,
                ..Default::default()
            };
            match payload(w.ty) {
                Some(Payload::Images) => write.p_image_info = w.images.as_ptr(),
                Some(Payload::Buffers) => write.p_buffer_info = w.buffers.as_ptr(),
                Some(Payload::TexelViews) => write.p_texel_buffer_view = w.texel_views.as_ptr(),
                Some(Payload::Inline) => {
                    write.p_next =
                        (block as *const vk::WriteDescriptorSetInlineUniformBlock<'_>).cast();
                }
                None => {}
            }
            write
        })
        .collect();
    // SAFETY: the caller's contract; the arrays live until the call returns.
    unsafe {
        push(
            buffer,
            vk::PipelineBindPoint::COMPUTE,
            layout,
            set,
            sent.len() as u32,
            sent.as_ptr(),
        )
    };
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

    fn kinds(compute: &ComputeBindings) -> Vec<(BindKind, u32)> {
        compute.binds.iter().map(|b| (b.kind, b.first)).collect()
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
        assert_eq!(
            kinds(&compute),
            [
                (BindKind::Sets { dynamic_offsets: 1 }, 0),
                (BindKind::BufferOffsets, 1),
                (BindKind::EmbeddedSamplers, 3)
            ]
        );
        assert_eq!(compute.binds[0].values, [1, 32]);
        assert_eq!(compute.binds[1].values, [0, 1, 256, 512]);
        assert_eq!(compute.binds[2].count, 1);
        // Offsets over sets 0 to 2 replace the sets bound at 0 and the offsets at 1..3.
        compute.set_buffer_offsets(layout, 0, &[0, 0, 0], &[0, 64, 128]);
        assert_eq!(
            kinds(&compute),
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
        assert_eq!(
            kinds(&compute),
            [
                (BindKind::EmbeddedSamplers, 1),
                (BindKind::Sets { dynamic_offsets: 0 }, 2)
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
    }

    fn views(images: &[vk::DescriptorImageInfo]) -> Vec<u64> {
        images.iter().map(|i| i.image_view.as_raw()).collect()
    }

    fn image(view: u64) -> vk::DescriptorImageInfo {
        vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: vk::ImageView::from_raw(view),
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        }
    }

    #[test]
    fn the_last_of_a_compute_pipeline_and_a_compute_shader_object_is_bound_again() {
        let mut compute = ComputeBindings::default();
        assert_eq!(compute.program, ComputeProgram::None);
        compute.bind_pipeline(vk::Pipeline::from_raw(3));
        compute.bind_shader(vk::ShaderEXT::from_raw(4));
        assert_eq!(
            compute.program,
            ComputeProgram::Shader(vk::ShaderEXT::from_raw(4))
        );
        compute.bind_pipeline(vk::Pipeline::from_raw(5));
        assert_eq!(
            compute.program,
            ComputeProgram::Pipeline(vk::Pipeline::from_raw(5))
        );
        assert!(compute.restorable(), "shader objects are bound again");
    }

    #[test]
    fn pushes_into_a_set_accumulate_until_one_writes_everything_an_earlier_one_wrote() {
        let layout = vk::PipelineLayout::from_raw(9);
        let images = [image(1), image(2)];
        let buffers = [vk::DescriptorBufferInfo {
            buffer: vk::Buffer::from_raw(3),
            offset: 16,
            range: 64,
        }];
        let both = [
            vk::WriteDescriptorSet::default()
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                .image_info(&images),
            vk::WriteDescriptorSet::default()
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .buffer_info(&buffers),
        ];
        let mut compute = ComputeBindings::default();
        // SAFETY: valid writes.
        unsafe { compute.push_writes(layout, 0, &both) };
        // Binding 1 alone: an incremental update, the first push still stands.
        // SAFETY: as above.
        unsafe { compute.push_writes(layout, 0, &both[1..]) };
        assert_eq!(
            kinds(&compute),
            [(BindKind::Pushed, 0), (BindKind::Pushed, 0)]
        );
        let first = &compute.binds[0].writes;
        assert_eq!(views(&first[0].images), [1, 2]);
        assert_eq!(first[1].buffers[0].offset, 16);
        // Both bindings again: it replaces both earlier pushes.
        // SAFETY: as above.
        unsafe { compute.push_writes(layout, 0, &both) };
        assert_eq!(kinds(&compute), [(BindKind::Pushed, 0)]);
        // A set bind of set 0 replaces the push; one of set 1 does not.
        compute.bind_sets(layout, 1, &sets(&[5]), &[]);
        assert_eq!(compute.binds.len(), 2);
        compute.bind_sets(layout, 0, &sets(&[6]), &[]);
        assert_eq!(
            kinds(&compute),
            [
                (BindKind::Sets { dynamic_offsets: 0 }, 1),
                (BindKind::Sets { dynamic_offsets: 0 }, 0)
            ]
        );
        assert!(compute.restorable());
    }

    #[test]
    fn a_template_push_is_kept_as_the_writes_its_entries_read() {
        let layout = vk::PipelineLayout::from_raw(9);
        // An image info at 0, a buffer info at 24, 8 inline bytes at 48.
        #[repr(C)]
        struct Data {
            image: vk::DescriptorImageInfo,
            buffer: vk::DescriptorBufferInfo,
            inline: [u8; 8],
        }
        let data = Data {
            image: image(7),
            buffer: vk::DescriptorBufferInfo {
                buffer: vk::Buffer::from_raw(8),
                offset: 0,
                range: vk::WHOLE_SIZE,
            },
            inline: [1, 2, 3, 4, 5, 6, 7, 8],
        };
        let entry = |binding, ty, offset, count| vk::DescriptorUpdateTemplateEntry {
            dst_binding: binding,
            dst_array_element: 0,
            descriptor_count: count,
            descriptor_type: ty,
            offset,
            stride: 0,
        };
        let entries = [
            entry(0, vk::DescriptorType::COMBINED_IMAGE_SAMPLER, 0, 1),
            entry(1, vk::DescriptorType::UNIFORM_BUFFER, 24, 1),
            entry(2, vk::DescriptorType::INLINE_UNIFORM_BLOCK, 48, 8),
        ];
        let mut compute = ComputeBindings::default();
        // SAFETY: data laid out as the entries say.
        unsafe {
            compute.push_template(layout, 2, &entries, (&data as *const Data).cast());
        }
        assert!(compute.restorable());
        let writes = &compute.binds[0].writes;
        assert_eq!(compute.binds[0].first, 2);
        assert_eq!(views(&writes[0].images), [7]);
        assert_eq!(writes[1].buffers[0].buffer, data.buffer.buffer);
        assert_eq!(writes[2].inline, data.inline);
        // An acceleration structure's entry is not copied: not restorable.
        let unknown = [entry(
            0,
            vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
            0,
            1,
        )];
        // SAFETY: as above (the entry is never read).
        unsafe {
            compute.push_template(layout, 0, &unknown, (&data as *const Data).cast());
        }
        assert!(!compute.restorable());
    }

    #[test]
    fn a_write_whose_array_is_null_is_not_restorable() {
        let layout = vk::PipelineLayout::from_raw(9);
        let write = vk::WriteDescriptorSet {
            descriptor_count: 1,
            descriptor_type: vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            ..Default::default()
        };
        let mut compute = ComputeBindings::default();
        // SAFETY: a write whose array is null (its chain and arrays are never followed).
        unsafe { compute.push_writes(layout, 0, &[write]) };
        assert!(!compute.restorable());
    }

    #[test]
    fn a_write_with_an_unknown_extension_structure_is_not_restorable() {
        let layout = vk::PipelineLayout::from_raw(9);
        let images = [image(1)];
        let unknown = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(1_000_999_000),
            ..Default::default()
        };
        let mut write = vk::WriteDescriptorSet::default()
            .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
            .image_info(&images);
        write.p_next = (&unknown as *const vk::BaseInStructure<'_>).cast();
        let mut compute = ComputeBindings::default();
        // SAFETY: a valid write (its chain is never followed).
        unsafe { compute.push_writes(layout, 0, &[write]) };
        assert!(!compute.restorable());
    }
}
