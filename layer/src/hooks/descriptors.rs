//! Descriptors of images that have a read twin (issue #39, `crate::depth_copy::twin`): every
//! way the application can write an image view into a descriptor hands down the twin's view
//! instead, in the twin's layout. `vkUpdateDescriptorSets` (copies of descriptor sets copy
//! what was written), update templates (`vkUpdateDescriptorSetWithTemplate`, and
//! `vkCmdPushDescriptorSetWithTemplate` in `command/compute_state.rs`), push descriptors
//! (`vkCmdPushDescriptorSet`, same file) and descriptor buffers (`vkGetDescriptorEXT`).
//! Only sampled-image and combined-image-sampler descriptors can name such a view: an image
//! with a twin has no storage or input attachment usage. While no twin is alive, every call
//! goes down as it is.

use std::sync::atomic::Ordering;

use ash::vk;

use super::*;
use crate::depth_copy::twin::TWIN_LAYOUT;
use crate::hooks::resources::slice;
use crate::state::DeviceState;

static UPDATE_DESCRIPTOR_SETS: EntryPoint = EntryPoint::new("vkUpdateDescriptorSets");
static UPDATE_WITH_TEMPLATE: EntryPoint = EntryPoint::new("vkUpdateDescriptorSetWithTemplate");
static GET_DESCRIPTOR: EntryPoint = EntryPoint::new("vkGetDescriptorEXT");

/// Whether a descriptor of `kind` can hold a view of an image with a read twin.
fn reads_images(kind: vk::DescriptorType) -> bool {
    matches!(
        kind,
        vk::DescriptorType::SAMPLED_IMAGE | vk::DescriptorType::COMBINED_IMAGE_SAMPLER
    )
}

/// Whether any read twin is alive on `device`.
pub fn any_twin(device: &DeviceState) -> bool {
    device.objects.twins.load(Ordering::Relaxed) != 0
}

/// Replaces views of images with a read twin by the twin's views, in its layout; whether any
/// was replaced.
pub fn patch_image_infos(device: &DeviceState, infos: &mut [vk::DescriptorImageInfo]) -> bool {
    let mut changed = false;
    for info in infos {
        if let Some(twin) = device.objects.twin_views.get(&info.image_view) {
            info.image_view = twin.view;
            info.image_layout = TWIN_LAYOUT;
            changed = true;
        }
    }
    changed
}

/// Descriptor writes with the views of images that have a twin replaced, and the image infos
/// they point at; `None` where no write names such a view.
pub struct PatchedWrites<'a> {
    pub writes: Vec<vk::WriteDescriptorSet<'a>>,
    _infos: Vec<Vec<vk::DescriptorImageInfo>>,
}

/// Patches `writes` ([`PatchedWrites`]).
///
/// # Safety
/// `writes` are valid descriptor writes.
pub unsafe fn patch_writes<'a>(
    device: &DeviceState,
    writes: &[vk::WriteDescriptorSet<'a>],
) -> Option<PatchedWrites<'a>> {
    let mut patched: Option<PatchedWrites<'a>> = None;
    for (index, write) in writes.iter().enumerate() {
        if !reads_images(write.descriptor_type) || write.p_image_info.is_null() {
            continue;
        }
        // SAFETY: `descriptorCount` image infos (the caller's contract).
        let mut infos = unsafe { slice(write.p_image_info, write.descriptor_count) }.to_vec();
        if !patch_image_infos(device, &mut infos) {
            continue;
        }
        let out = patched.get_or_insert_with(|| PatchedWrites {
            writes: writes.to_vec(),
            _infos: Vec::new(),
        });
        // The vector's buffer does not move when the vector is moved into `_infos`.
        out.writes[index].p_image_info = infos.as_ptr();
        out._infos.push(infos);
    }
    patched
}

pub unsafe extern "system" fn update_descriptor_sets(
    device: vk::Device,
    write_count: u32,
    p_writes: *const vk::WriteDescriptorSet<'_>,
    copy_count: u32,
    p_copies: *const vk::CopyDescriptorSet<'_>,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    let patched = if any_twin(&state) {
        guarded(
            &UPDATE_DESCRIPTOR_SETS,
            // SAFETY: `writeCount` valid writes (the application's contract).
            || unsafe { patch_writes(&state, slice(p_writes, write_count)) },
            || None,
        )
    } else {
        None
    };
    let (count, writes) = match &patched {
        Some(patched) => (patched.writes.len() as u32, patched.writes.as_ptr()),
        None => (write_count, p_writes),
    };
    // SAFETY: calling down with the application's arguments, or its writes naming the twins'
    // views.
    unsafe {
        (state.next.fp_v1_0().update_descriptor_sets)(device, count, writes, copy_count, p_copies)
    };
}

/// One entry of an update template that writes image infos revz may replace.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct ImageEntry {
    offset: usize,
    stride: usize,
    count: usize,
}

/// What a descriptor update template writes that matters here: the entries of image
/// descriptors, and the bytes of data it reads (`None`: an entry of a type whose size revz
/// does not know, such as `VK_DESCRIPTOR_TYPE_MUTABLE_EXT`: its data is never copied).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TemplateEntries {
    images: Vec<ImageEntry>,
    data_size: Option<usize>,
}

impl TemplateEntries {
    /// Reads a template's entries.
    pub fn of(entries: &[vk::DescriptorUpdateTemplateEntry]) -> TemplateEntries {
        let mut out = TemplateEntries {
            images: Vec::new(),
            data_size: Some(0),
        };
        for entry in entries {
            let count = entry.descriptor_count as usize;
            let element = match entry.descriptor_type {
                vk::DescriptorType::SAMPLER
                | vk::DescriptorType::COMBINED_IMAGE_SAMPLER
                | vk::DescriptorType::SAMPLED_IMAGE
                | vk::DescriptorType::STORAGE_IMAGE
                | vk::DescriptorType::INPUT_ATTACHMENT => {
                    Some(std::mem::size_of::<vk::DescriptorImageInfo>())
                }
                vk::DescriptorType::UNIFORM_BUFFER
                | vk::DescriptorType::STORAGE_BUFFER
                | vk::DescriptorType::UNIFORM_BUFFER_DYNAMIC
                | vk::DescriptorType::STORAGE_BUFFER_DYNAMIC => {
                    Some(std::mem::size_of::<vk::DescriptorBufferInfo>())
                }
                vk::DescriptorType::UNIFORM_TEXEL_BUFFER
                | vk::DescriptorType::STORAGE_TEXEL_BUFFER => {
                    Some(std::mem::size_of::<vk::BufferView>())
                }
                vk::DescriptorType::ACCELERATION_STRUCTURE_KHR
                | vk::DescriptorType::ACCELERATION_STRUCTURE_NV => Some(8),
                _ => None,
            };
            // Inline uniform blocks: `descriptorCount` bytes at `offset`.
            let end = if entry.descriptor_type == vk::DescriptorType::INLINE_UNIFORM_BLOCK {
                Some(entry.offset + count)
            } else if count == 0 {
                Some(0)
            } else {
                element.map(|size| entry.offset + entry.stride * (count - 1) + size)
            };
            out.data_size = match (out.data_size, end) {
                (Some(size), Some(end)) => Some(size.max(end)),
                _ => None,
            };
            if reads_images(entry.descriptor_type) && count > 0 {
                out.images.push(ImageEntry {
                    offset: entry.offset,
                    stride: entry.stride,
                    count,
                });
            }
        }
        out
    }

    /// Whether the template writes image descriptors revz may replace.
    pub fn writes_images(&self) -> bool {
        !self.images.is_empty()
    }

    /// A copy of `data` with the views of images that have a twin replaced; `None` where
    /// there is none (or the data's size is unknown).
    ///
    /// # Safety
    /// `data` is the application's valid data for this template.
    pub unsafe fn patch(
        &self,
        device: &DeviceState,
        data: *const std::ffi::c_void,
    ) -> Option<Vec<u64>> {
        let size = self.data_size?;
        if data.is_null() || size == 0 {
            return None;
        }
        // Eight-byte words, so that the copy is aligned for handles and image infos.
        let mut copy = vec![0u64; size.div_ceil(8)];
        // SAFETY: the template reads `size` bytes of `data` (the caller's contract).
        unsafe { std::ptr::copy_nonoverlapping(data.cast::<u8>(), copy.as_mut_ptr().cast(), size) };
        let base = copy.as_mut_ptr().cast::<u8>();
        let mut changed = false;
        for entry in &self.images {
            for i in 0..entry.count {
                let offset = entry.offset + entry.stride * i;
                // SAFETY: within the copy (`data_size` covers every entry); read unaligned,
                // as the application may lay its data out at any offset.
                let info_ptr = unsafe { base.add(offset) }.cast::<vk::DescriptorImageInfo>();
                // SAFETY: as above.
                let mut info = unsafe { info_ptr.read_unaligned() };
                if patch_image_infos(device, std::slice::from_mut(&mut info)) {
                    // SAFETY: as above.
                    unsafe { info_ptr.write_unaligned(info) };
                    changed = true;
                }
            }
        }
        changed.then_some(copy)
    }
}

/// The template's data with the twins' views in place; `None`: the application's data as
/// it is.
///
/// # Safety
/// `data` is the application's valid data for `template`.
pub unsafe fn patch_template_data(
    device: &DeviceState,
    template: vk::DescriptorUpdateTemplate,
    data: *const std::ffi::c_void,
) -> Option<Vec<u64>> {
    if !any_twin(device) {
        return None;
    }
    let entries = device.objects.templates.get(&template)?;
    // SAFETY: the caller's contract.
    unsafe { entries.patch(device, data) }
}

pub unsafe extern "system" fn update_descriptor_set_with_template(
    device: vk::Device,
    set: vk::DescriptorSet,
    template: vk::DescriptorUpdateTemplate,
    p_data: *const std::ffi::c_void,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    let Some(next) = state.commands.update_descriptor_set_with_template else {
        return;
    };
    let patched = guarded(
        &UPDATE_WITH_TEMPLATE,
        // SAFETY: the application's data for its template.
        || unsafe { patch_template_data(&state, template, p_data) },
        || None,
    );
    let data = patched.as_ref().map_or(p_data, |copy| copy.as_ptr().cast());
    // SAFETY: calling down with the application's arguments, or its data naming the twins'
    // views.
    unsafe { next(device, set, template, data) }
}

/// `vkGetDescriptorEXT` (descriptor buffers): a sampled image or combined image sampler
/// descriptor of a view with a twin is made of the twin's view.
pub unsafe extern "system" fn get_descriptor_ext(
    device: vk::Device,
    p_info: *const vk::DescriptorGetInfoEXT<'_>,
    data_size: usize,
    p_descriptor: *mut std::ffi::c_void,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    let Some(next) = state.commands.get_descriptor_ext else {
        return;
    };
    let patched = guarded(
        &GET_DESCRIPTOR,
        || {
            if !any_twin(&state) {
                return None;
            }
            // SAFETY: a valid info (the application's contract).
            let info = unsafe { &*p_info };
            // SAFETY: the member the type names is the one set.
            let image = unsafe {
                match info.ty {
                    vk::DescriptorType::SAMPLED_IMAGE => info.data.p_sampled_image,
                    vk::DescriptorType::COMBINED_IMAGE_SAMPLER => {
                        info.data.p_combined_image_sampler
                    }
                    _ => return None,
                }
            };
            // SAFETY: null or a valid image info.
            let mut image_info = unsafe { image.as_ref() }.copied()?;
            patch_image_infos(&state, std::slice::from_mut(&mut image_info))
                .then_some((*info, image_info))
        },
        || None,
    );
    match patched {
        Some((mut info, image_info)) => {
            if info.ty == vk::DescriptorType::SAMPLED_IMAGE {
                info.data.p_sampled_image = &image_info;
            } else {
                info.data.p_combined_image_sampler = &image_info;
            }
            // SAFETY: the application's query with the twin's view.
            unsafe { next(device, &info, data_size, p_descriptor) }
        }
        // SAFETY: calling down with the application's arguments.
        None => unsafe { next(device, p_info, data_size, p_descriptor) },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(
        kind: vk::DescriptorType,
        offset: usize,
        stride: usize,
        count: u32,
    ) -> vk::DescriptorUpdateTemplateEntry {
        vk::DescriptorUpdateTemplateEntry {
            dst_binding: 0,
            dst_array_element: 0,
            descriptor_count: count,
            descriptor_type: kind,
            offset,
            stride,
        }
    }

    #[test]
    fn a_templates_data_size_covers_every_entry() {
        let entries = TemplateEntries::of(&[
            entry(vk::DescriptorType::UNIFORM_BUFFER, 0, 24, 1),
            entry(vk::DescriptorType::COMBINED_IMAGE_SAMPLER, 32, 40, 3),
            entry(vk::DescriptorType::INLINE_UNIFORM_BLOCK, 200, 0, 16),
            entry(vk::DescriptorType::STORAGE_TEXEL_BUFFER, 120, 8, 2),
        ]);
        // 32 + 2 * 40 + 24 = 136; the inline block ends at 216.
        assert_eq!(entries.data_size, Some(216));
        assert_eq!(
            entries.images,
            [ImageEntry {
                offset: 32,
                stride: 40,
                count: 3
            }]
        );
        assert!(entries.writes_images());
        let unknown = TemplateEntries::of(&[
            entry(vk::DescriptorType::SAMPLED_IMAGE, 0, 24, 1),
            entry(vk::DescriptorType::MUTABLE_EXT, 24, 8, 1),
        ]);
        assert_eq!(unknown.data_size, None);
        let buffers = TemplateEntries::of(&[entry(vk::DescriptorType::STORAGE_BUFFER, 0, 24, 4)]);
        assert!(!buffers.writes_images());
        assert_eq!(buffers.data_size, Some(96));
    }
}
