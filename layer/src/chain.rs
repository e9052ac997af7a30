//! Reading the application's `pNext` chains. revz only reads them: structures it does not know
//! are skipped here and reach the next layer untouched, and a structure revz must change is
//! copied by the caller, never written in place.

use std::ffi::c_void;

use ash::vk;

/// Each structure of a `pNext` chain, in order.
///
/// # Safety
/// `p_next` must be null or the head of a valid structure chain that lives for `'a` (every
/// structure starts like `VkBaseInStructure`).
pub unsafe fn structures<'a>(
    p_next: *const c_void,
) -> impl Iterator<Item = &'a vk::BaseInStructure<'a>> {
    let mut next = p_next.cast::<vk::BaseInStructure<'a>>();
    std::iter::from_fn(move || {
        // SAFETY: the caller's contract.
        let base = unsafe { next.as_ref() }?;
        next = base.p_next;
        Some(base)
    })
}

/// The first structure of `T`'s type in a `pNext` chain.
///
/// # Safety
/// As [`structures`].
pub unsafe fn find<'a, T: vk::TaggedStructure + 'a>(p_next: *const c_void) -> Option<&'a T> {
    // SAFETY: the caller's contract.
    let found = unsafe { structures(p_next) }.find(|base| base.s_type == T::STRUCTURE_TYPE)?;
    // SAFETY: the sType identifies the structure.
    Some(unsafe { &*(found as *const vk::BaseInStructure<'_>).cast::<T>() })
}

/// Whether a `pNext` chain holds a structure of type `s_type`.
///
/// # Safety
/// As [`structures`].
pub unsafe fn has(p_next: *const c_void, s_type: vk::StructureType) -> bool {
    // SAFETY: the caller's contract.
    unsafe { structures(p_next) }.any(|base| base.s_type == s_type)
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
}
