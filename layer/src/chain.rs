//! Reading the application's `pNext` chains, and splicing copies of them. revz never writes
//! the application's chains: structures it does not know are skipped here and reach the next
//! layer untouched, and a chain in which revz must change or leave out a structure is
//! [`splice`]d: the structures before it are copied, the rest is shared.

use std::ffi::c_void;

use ash::vk;

/// Each structure of a `pNext` chain, in order, with its type: pointers to the whole
/// structures, from which the structure itself may be read (a reference to its
/// `VkBaseInStructure` would cover only the header's bytes).
///
/// # Safety
/// As [`structures`].
unsafe fn pointers(
    p_next: *const c_void,
) -> impl Iterator<Item = (vk::StructureType, *const vk::BaseInStructure<'static>)> {
    let mut next = p_next.cast::<vk::BaseInStructure<'static>>();
    std::iter::from_fn(move || {
        if next.is_null() {
            return None;
        }
        let structure = next;
        // SAFETY: the caller's contract: a structure of the chain, which starts like
        // `VkBaseInStructure`.
        let s_type = unsafe {
            next = (*structure).p_next;
            (*structure).s_type
        };
        Some((s_type, structure))
    })
}

/// Each structure of a `pNext` chain, in order.
///
/// # Safety
/// `p_next` must be null or the head of a valid structure chain that lives for `'a` (every
/// structure starts like `VkBaseInStructure`).
pub unsafe fn structures<'a>(
    p_next: *const c_void,
) -> impl Iterator<Item = &'a vk::BaseInStructure<'a>> {
    // SAFETY: the caller's contract.
    unsafe { pointers(p_next) }.map(|(_, structure)| {
        // SAFETY: the caller's contract.
        unsafe { &*structure.cast::<vk::BaseInStructure<'a>>() }
    })
}

/// The first structure of `T`'s type in a `pNext` chain.
///
/// # Safety
/// As [`structures`].
pub unsafe fn find<'a, T: vk::TaggedStructure + 'a>(p_next: *const c_void) -> Option<&'a T> {
    // SAFETY: the caller's contract.
    let (_, found) =
        unsafe { pointers(p_next) }.find(|&(s_type, _)| s_type == T::STRUCTURE_TYPE)?;
    // SAFETY: the sType identifies the structure.
    Some(unsafe { &*found.cast::<T>() })
}

/// Whether a `pNext` chain holds a structure of type `s_type`.
///
/// # Safety
/// As [`structures`].
pub unsafe fn has(p_next: *const c_void, s_type: vk::StructureType) -> bool {
    // SAFETY: the caller's contract.
    unsafe { structures(p_next) }.any(|base| base.s_type == s_type)
}

/// A copy of the head of a `pNext` chain in which one structure is replaced or left out (see
/// [`splice`]). The copies live as long as this value; the rest of the chain is the
/// application's.
#[derive(Debug)]
pub struct Spliced {
    /// The copied structures, each in its own 8-byte-aligned buffer (buffers do not move when
    /// this vector grows).
    copies: Vec<Vec<u64>>,
    head: *const c_void,
}

impl Spliced {
    /// The application's chain, not spliced yet.
    pub fn of(p_next: *const c_void) -> Spliced {
        Spliced {
            copies: Vec::new(),
            head: p_next,
        }
    }

    /// The head of the spliced chain, to give in place of the application's.
    pub fn head(&self) -> *const c_void {
        self.head
    }

    /// Replaces the first structure of `T`'s type in the chain as spliced so far by the copy
    /// `edit` makes of it, where it makes one ([`splice`] on the current head; the copies
    /// made before stay alive, as the new ones may point into them). `Err` when the structure
    /// cannot be spliced (a structure of unknown size before it): the chain is left as it was.
    ///
    /// # Safety
    /// As [`splice`].
    pub unsafe fn edit<T: vk::TaggedStructure>(
        &mut self,
        edit: impl FnOnce(&T) -> Option<T>,
    ) -> Result<(), Unspliceable> {
        // SAFETY: the caller's contract.
        let Some(replacement) = unsafe { find::<T>(self.head) }.and_then(edit) else {
            return Ok(());
        };
        // SAFETY: the caller's contract.
        let spliced = unsafe { splice(self.head, Some(&replacement)) }.ok_or(Unspliceable)?;
        self.copies.extend(spliced.copies);
        self.head = spliced.head;
        Ok(())
    }

    /// Copies `size` bytes of a structure, points the copy's `pNext` at `p_next`, keeps it
    /// and returns where it is.
    ///
    /// # Safety
    /// `structure` points to at least `size` readable bytes of a structure (8-byte alignment
    /// at most, as every Vulkan structure).
    unsafe fn copy(
        &mut self,
        structure: *const c_void,
        size: usize,
        p_next: *const c_void,
    ) -> *const c_void {
        let mut copy = vec![0u64; size.div_ceil(8)];
        let bytes = copy.as_mut_ptr().cast::<u8>();
        // SAFETY: the caller's contract; the copy has room for `size` bytes, and every
        // structure starts like `VkBaseOutStructure`.
        unsafe {
            std::ptr::copy_nonoverlapping(structure.cast::<u8>(), bytes, size);
            (*bytes.cast::<vk::BaseOutStructure<'_>>()).p_next = p_next.cast_mut().cast();
        }
        // Written before it is stored: moving the vector leaves its buffer where it is.
        self.copies.push(copy);
        self.copies
            .last()
            .map_or(std::ptr::null(), |copy| copy.as_ptr().cast())
    }
}

/// A structure of a type revz does not know the size of comes before the one to splice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unspliceable;

/// The structures that may come before the one revz splices out of a graphics pipeline's or a
/// shader stage's chain, with their byte sizes: only structures of known size can be copied.
pub(crate) const KNOWN_SIZES: &[(vk::StructureType, usize)] = {
    macro_rules! sizes {
        ($($structure:ty),* $(,)?) => {
            &[$((
                <$structure as vk::TaggedStructure>::STRUCTURE_TYPE,
                std::mem::size_of::<$structure>(),
            )),*]
        };
    }
    sizes!(
        // VkGraphicsPipelineCreateInfo
        vk::AttachmentSampleCountInfoAMD<'static>,
        vk::ExternalFormatANDROID<'static>,
        vk::GraphicsPipelineLibraryCreateInfoEXT<'static>,
        vk::GraphicsPipelineShaderGroupsCreateInfoNV<'static>,
        vk::MultiviewPerViewAttributesInfoNVX<'static>,
        vk::PipelineCompilerControlCreateInfoAMD<'static>,
        vk::PipelineCreateFlags2CreateInfoKHR<'static>,
        vk::PipelineCreationFeedbackCreateInfo<'static>,
        vk::PipelineDiscardRectangleStateCreateInfoEXT<'static>,
        vk::PipelineFragmentShadingRateEnumStateCreateInfoNV<'static>,
        vk::PipelineFragmentShadingRateStateCreateInfoKHR<'static>,
        vk::PipelineLibraryCreateInfoKHR<'static>,
        vk::PipelineRenderingCreateInfo<'static>,
        vk::PipelineRepresentativeFragmentTestStateCreateInfoNV<'static>,
        vk::PipelineRobustnessCreateInfoEXT<'static>,
        vk::RenderingAttachmentLocationInfoKHR<'static>,
        vk::RenderingInputAttachmentIndexInfoKHR<'static>,
        // VkImageCreateInfo (before its format list)
        vk::DedicatedAllocationImageCreateInfoNV<'static>,
        vk::ExternalMemoryImageCreateInfo<'static>,
        vk::ImageCompressionControlEXT<'static>,
        vk::ImageStencilUsageCreateInfo<'static>,
        vk::ImageSwapchainCreateInfoKHR<'static>,
        vk::OpaqueCaptureDescriptorDataCreateInfoEXT<'static>,
        // VkCommandBufferInheritanceInfo (before its rendering info)
        vk::CommandBufferInheritanceConditionalRenderingInfoEXT<'static>,
        vk::CommandBufferInheritanceViewportScissorInfoNV<'static>,
        vk::RenderPassTransformBeginInfoQCOM<'static>,
        // VkPipelineShaderStageCreateInfo
        vk::DebugUtilsObjectNameInfoEXT<'static>,
        vk::PipelineShaderStageModuleIdentifierCreateInfoEXT<'static>,
        vk::PipelineShaderStageRequiredSubgroupSizeCreateInfo<'static>,
        vk::ShaderModuleCreateInfo<'static>,
        vk::ShaderModuleValidationCacheCreateInfoEXT<'static>,
    )
};

/// The byte size of a structure of `s_type`, if revz knows it ([`KNOWN_SIZES`]).
fn known_size(s_type: vk::StructureType) -> Option<usize> {
    KNOWN_SIZES
        .iter()
        .find(|&&(known, _)| known == s_type)
        .map(|&(_, size)| size)
}

/// Whether [`splice`] of `T` out of the chain `p_next` would fail although the chain holds a
/// `T`: a structure of a type revz does not know the size of comes before it.
///
/// # Safety
/// As [`structures`].
pub unsafe fn splice_blocked<T: vk::TaggedStructure>(p_next: *const c_void) -> bool {
    let mut unknown_before = false;
    // SAFETY: the caller's contract.
    for (s_type, _) in unsafe { pointers(p_next) } {
        if s_type == T::STRUCTURE_TYPE {
            return unknown_before;
        }
        unknown_before |= known_size(s_type).is_none();
    }
    false
}

/// The chain `p_next` with its first structure of `T`'s type replaced by `replacement`, or
/// left out when `replacement` is `None`: the structures before it are copied, the
/// replacement's own `pNext` is ignored (it takes the original's), and the structures after
/// it are the application's. `None` when the chain holds no `T`, or when a structure before
/// it is of a type revz does not know the size of (it cannot be copied).
///
/// # Safety
/// As [`structures`]; the chain must outlive every use of the splice's head.
pub unsafe fn splice<T: vk::TaggedStructure>(
    p_next: *const c_void,
    replacement: Option<&T>,
) -> Option<Spliced> {
    // The structures before the target: where each is and how many bytes to copy.
    let mut before: Vec<(*const c_void, Option<usize>)> = Vec::new();
    // SAFETY: the caller's contract.
    let (_, target) = unsafe { pointers(p_next) }.find(|&(s_type, structure)| {
        let found = s_type == T::STRUCTURE_TYPE;
        if !found {
            before.push((structure.cast(), known_size(s_type)));
        }
        found
    })?;
    // SAFETY: as above.
    let target_next = unsafe { (*target).p_next }.cast::<c_void>();
    let mut copied = Vec::with_capacity(before.len() + 1);
    for (structure, size) in before {
        copied.push((structure, size?));
    }
    if let Some(replacement) = replacement {
        copied.push(((replacement as *const T).cast(), std::mem::size_of::<T>()));
    }
    let mut spliced = Spliced {
        copies: Vec::with_capacity(copied.len()),
        head: target_next,
    };
    // Copied from the end towards the head, each copy pointing at the one made before it.
    for (structure, size) in copied.into_iter().rev() {
        // SAFETY: a structure of the chain of a known size, or the caller's replacement.
        spliced.head = unsafe { spliced.copy(structure, size, spliced.head) };
    }
    Some(spliced)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_first_structure_of_a_type_and_skips_unknown_ones() {
        let unknown = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(1_000_999_000),
            ..Default::default()
        };
        let control = vk::PipelineViewportDepthClipControlCreateInfoEXT {
            p_next: (&unknown as *const vk::BaseInStructure<'_>).cast(),
            negative_one_to_one: vk::TRUE,
            ..Default::default()
        };
        let head = (&control as *const vk::PipelineViewportDepthClipControlCreateInfoEXT<'_>)
            .cast::<c_void>();
        // SAFETY: a valid chain of two structures on the stack.
        unsafe {
            assert_eq!(structures(head).count(), 2);
            let found = find::<vk::PipelineViewportDepthClipControlCreateInfoEXT<'_>>(head);
            assert_eq!(found.map(|c| c.negative_one_to_one), Some(vk::TRUE));
            assert!(find::<vk::PipelineRenderingCreateInfo<'_>>(head).is_none());
            assert!(has(head, unknown.s_type));
            assert!(!has(std::ptr::null(), unknown.s_type));
        }
    }

    /// The structure types of a chain, in order, and where each is.
    fn walk(head: *const c_void) -> Vec<(vk::StructureType, usize)> {
        // SAFETY: the tests' chains are valid.
        unsafe { structures(head) }
            .map(|base| (base.s_type, base as *const vk::BaseInStructure<'_> as usize))
            .collect()
    }

    #[test]
    fn a_splice_copies_what_comes_before_replaces_the_structure_and_shares_the_rest() {
        let unknown = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(1_000_999_000),
            ..Default::default()
        };
        let flags2 = vk::PipelineCreateFlags2CreateInfoKHR {
            p_next: (&unknown as *const vk::BaseInStructure<'_>).cast(),
            flags: vk::PipelineCreateFlags2KHR::FAIL_ON_PIPELINE_COMPILE_REQUIRED
                | vk::PipelineCreateFlags2KHR::LIBRARY,
            ..Default::default()
        };
        let formats = [vk::Format::R8G8B8A8_UNORM];
        let rendering = vk::PipelineRenderingCreateInfo {
            p_next: (&flags2 as *const vk::PipelineCreateFlags2CreateInfoKHR<'_>).cast(),
            depth_attachment_format: vk::Format::D32_SFLOAT,
            ..Default::default()
        }
        .color_attachment_formats(&formats);
        let head = (&rendering as *const vk::PipelineRenderingCreateInfo<'_>).cast::<c_void>();
        let original = walk(head);

        // The replacement's own pNext is not followed.
        let replacement = vk::PipelineCreateFlags2CreateInfoKHR {
            p_next: 0x10 as *const c_void,
            flags: vk::PipelineCreateFlags2KHR::LIBRARY,
            ..Default::default()
        };
        // SAFETY: a valid chain on the stack that outlives the splice.
        let spliced = unsafe { splice(head, Some(&replacement)) }.expect("spliced");
        let chain = walk(spliced.head());
        assert_eq!(
            chain.iter().map(|(s_type, _)| *s_type).collect::<Vec<_>>(),
            original
                .iter()
                .map(|(s_type, _)| *s_type)
                .collect::<Vec<_>>()
        );
        assert_ne!(chain[0].1, original[0].1, "the structure before is a copy");
        assert_ne!(chain[1].1, original[1].1, "the replacement is a copy");
        assert_eq!(chain[2], original[2], "the rest is the application's");
        // SAFETY: the spliced chain lives as long as `spliced`.
        unsafe {
            let copy = find::<vk::PipelineRenderingCreateInfo<'_>>(spliced.head()).unwrap();
            assert_eq!(copy.depth_attachment_format, vk::Format::D32_SFLOAT);
            assert_eq!(copy.p_color_attachment_formats, formats.as_ptr());
            let replaced = find::<vk::PipelineCreateFlags2CreateInfoKHR<'_>>(spliced.head());
            assert_eq!(
                replaced.map(|f| f.flags),
                Some(vk::PipelineCreateFlags2KHR::LIBRARY)
            );
        }
        assert_eq!(walk(head), original, "the application's chain is unchanged");
        assert_eq!(
            flags2.flags,
            vk::PipelineCreateFlags2KHR::FAIL_ON_PIPELINE_COMPILE_REQUIRED
                | vk::PipelineCreateFlags2KHR::LIBRARY
        );
    }

    #[test]
    fn a_splice_can_leave_a_structure_out() {
        let unknown = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(1_000_999_000),
            ..Default::default()
        };
        let code = [0x0723_0203u32];
        let inline = vk::ShaderModuleCreateInfo {
            p_next: (&unknown as *const vk::BaseInStructure<'_>).cast(),
            ..Default::default()
        }
        .code(&code);
        let name = vk::DebugUtilsObjectNameInfoEXT {
            p_next: (&inline as *const vk::ShaderModuleCreateInfo<'_>).cast(),
            ..Default::default()
        };
        let head = (&name as *const vk::DebugUtilsObjectNameInfoEXT<'_>).cast::<c_void>();
        // SAFETY: a valid chain on the stack that outlives the splice.
        let spliced =
            unsafe { splice::<vk::ShaderModuleCreateInfo<'_>>(head, None) }.expect("spliced");
        let chain = walk(spliced.head());
        assert_eq!(
            chain.iter().map(|(s_type, _)| *s_type).collect::<Vec<_>>(),
            [name.s_type, unknown.s_type]
        );
        assert_eq!(chain[1].1, &unknown as *const _ as usize);

        // First in the chain: nothing is copied, the head is what followed it.
        let head = (&inline as *const vk::ShaderModuleCreateInfo<'_>).cast::<c_void>();
        // SAFETY: as above.
        let spliced =
            unsafe { splice::<vk::ShaderModuleCreateInfo<'_>>(head, None) }.expect("spliced");
        assert_eq!(spliced.head(), inline.p_next);
    }

    #[test]
    fn a_splice_needs_the_structure_and_copies_only_structures_of_known_size() {
        let flags2 = vk::PipelineCreateFlags2CreateInfoKHR::default();
        let unknown = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(1_000_999_000),
            p_next: (&flags2 as *const vk::PipelineCreateFlags2CreateInfoKHR<'_>).cast(),
            ..Default::default()
        };
        let head = (&unknown as *const vk::BaseInStructure<'_>).cast::<c_void>();
        // SAFETY: valid chains on the stack.
        unsafe {
            assert!(
                splice(head, Some(&flags2)).is_none(),
                "unknown size before it"
            );
            assert!(splice_blocked::<vk::PipelineCreateFlags2CreateInfoKHR<'_>>(
                head
            ));
            let missing = vk::PipelineRenderingCreateInfo::default();
            assert!(splice(head, Some(&missing)).is_none(), "not in the chain");
            assert!(splice(std::ptr::null(), Some(&missing)).is_none());
            // Blocked only where the chain holds the structure after an unknown one.
            assert!(!splice_blocked::<vk::PipelineRenderingCreateInfo<'_>>(head));
            let first = (&flags2 as *const vk::PipelineCreateFlags2CreateInfoKHR<'_>).cast();
            assert!(!splice_blocked::<vk::PipelineCreateFlags2CreateInfoKHR<'_>>(first));
            assert!(splice(first, Some(&flags2)).is_some());
        }
    }

    #[test]
    fn edits_stack_and_keep_what_earlier_edits_copied() {
        let unknown = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(1_000_999_000),
            ..Default::default()
        };
        let flags2 = vk::PipelineCreateFlags2CreateInfoKHR {
            p_next: (&unknown as *const vk::BaseInStructure<'_>).cast(),
            flags: vk::PipelineCreateFlags2KHR::LIBRARY
                | vk::PipelineCreateFlags2KHR::EARLY_RETURN_ON_FAILURE,
            ..Default::default()
        };
        let libraries = [vk::Pipeline::null()];
        let links = vk::PipelineLibraryCreateInfoKHR {
            p_next: (&flags2 as *const vk::PipelineCreateFlags2CreateInfoKHR<'_>).cast(),
            ..Default::default()
        }
        .libraries(&libraries);
        let head = (&links as *const vk::PipelineLibraryCreateInfoKHR<'_>).cast::<c_void>();
        let original = walk(head);
        let mut chain = Spliced::of(head);
        let replaced = [vk::Pipeline::null(); 2];
        // SAFETY: a valid chain on the stack that outlives the splices.
        unsafe {
            // The later structure first, then the one before it (whose copy points at the
            // first edit's copy); an edit that makes no copy changes nothing.
            chain
                .edit(|f: &vk::PipelineCreateFlags2CreateInfoKHR<'_>| {
                    Some(f.flags(vk::PipelineCreateFlags2KHR::LIBRARY))
                })
                .unwrap();
            chain
                .edit(|l: &vk::PipelineLibraryCreateInfoKHR<'_>| Some(l.libraries(&replaced)))
                .unwrap();
            chain
                .edit(|_: &vk::PipelineRenderingCreateInfo<'_>| None)
                .unwrap();
            let edited = walk(chain.head());
            assert_eq!(
                edited.iter().map(|(s_type, _)| *s_type).collect::<Vec<_>>(),
                original
                    .iter()
                    .map(|(s_type, _)| *s_type)
                    .collect::<Vec<_>>()
            );
            assert_eq!(edited[2], original[2], "the rest is the application's");
            let found = find::<vk::PipelineLibraryCreateInfoKHR<'_>>(chain.head()).unwrap();
            assert_eq!(found.library_count, 2);
            let found = find::<vk::PipelineCreateFlags2CreateInfoKHR<'_>>(chain.head()).unwrap();
            assert_eq!(found.flags, vk::PipelineCreateFlags2KHR::LIBRARY);
        }
        assert_eq!(walk(head), original, "the application's chain is unchanged");

        // Behind a structure of unknown size: refused, the chain left as it was.
        let rendering = vk::PipelineRenderingCreateInfo::default();
        let behind = vk::BaseInStructure {
            s_type: unknown.s_type,
            p_next: (&rendering as *const vk::PipelineRenderingCreateInfo<'_>).cast(),
            ..Default::default()
        };
        let head = (&behind as *const vk::BaseInStructure<'_>).cast::<c_void>();
        let mut chain = Spliced::of(head);
        // SAFETY: as above.
        let refused =
            unsafe { chain.edit(|r: &vk::PipelineRenderingCreateInfo<'_>| Some(r.view_mask(1))) };
        assert_eq!(refused, Err(Unspliceable));
        assert_eq!(chain.head(), head);
    }
}
