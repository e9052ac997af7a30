//! Read twins (issue #39): what shaders read in place of a reversed depth image.
//!
//! A reversed image that shaders sample (`crate::policy::DevicePolicy::reads_through_twin`)
//! gets a twin at its creation: a native image of the application's format, size, mip levels
//! and layers, in revz's own memory. Every view of the image gets a view of the twin beside
//! it, and descriptors receive the twin's view (`crate::hooks::descriptors`). Whenever the
//! application makes the image readable after writing it (an image barrier or a
//! `vkCmdWaitEvents` into a read-only layout, a render pass ending in one:
//! `crate::hooks::command::twins`), the barrier's subresources are refreshed: copied out of
//! the image through the conversion of copies ([`super::record`]), mapped back to standard
//! depth, into the twin; the stencil aspect is copied as it is.
//!
//! A promoted image's twin is UNORM (the application's D16 / D24 format), so that a shader
//! reads the texel the application's format would hold: a float32 twin gives `1 - (1 - d)`,
//! up to an ulp from the UNORM value `d`, and a comparison against a reference equal to the
//! texel (as OpenGL's conformance tests make) then fails. Its refresh converts float32 into
//! UNORM through the conversion of copies, the stencil going through revz's scratch buffer
//! with the depth (no image copy goes between two formats); where the image holds standard
//! depth, the conversion only changes the format.
//!
//! A refresh, in the application's command buffer, outside a render pass:
//!
//! 1. one barrier: everything before (all commands, all memory writes) before the transfer;
//!    the image from the application's new layout to `TRANSFER_SRC_OPTIMAL`; the twin's
//!    subresources from `UNDEFINED` (they are overwritten whole) to `TRANSFER_DST_OPTIMAL`;
//! 2. the depth converted into the twin (a plain copy where the image is native in the
//!    twin's format: demoted, or the application's own reversed depth), the stencil copied
//!    (converted with the depth into a promoted image's twin);
//! 3. one barrier: the image back to the application's layout, the twin to
//!    `SHADER_READ_ONLY_OPTIMAL`, before every later command.
//!
//! Descriptors name the twin in `SHADER_READ_ONLY_OPTIMAL` whatever layout the application
//! named. A twin subresource is read only after a refresh put it there, unless the
//! application samples a subresource it never made readable (which it may not either).
//!
//! A **multisampled** image cannot be copied through a buffer, so its twin is refreshed per
//! sample by a compute pass instead (`depth_convert_ms.comp`): the twin is an `R32_SFLOAT`
//! image of as many samples (storage and sampled), which shaders read as they read a depth
//! image (the depth in the first component: a multisampled image is only fetched, never
//! filtered or compared); the dispatch fetches every sample of the image's depth through a
//! view of revz's own and stores it mapped back to standard depth. Views of the image's depth
//! get views of the twin; its stencil is read from the image itself (never reversed). The
//! refresh: one barrier (the image from the application's layout to
//! `SHADER_READ_ONLY_OPTIMAL`, the twin from `UNDEFINED` to `GENERAL`), the map written into
//! the command buffer's scratch buffer, the dispatch, one barrier back (the twin to
//! `SHADER_READ_ONLY_OPTIMAL`), and the application's compute state bound again.

use ash::vk;

use super::plan::{plan_image_copy, DepthMap, ShaderHeader, TexelKinds};
use super::record::{image_barrier, pipeline_barrier, record, Conversion, Drain, Fill};
use super::scratch::CommandCopies;
use crate::objects::{MultisampledBindings, ReadTwin};
use crate::policy::Unconverted;
use crate::state::DeviceState;

/// The layout descriptors name a twin's views in, and the one it is left in after a refresh.
pub const TWIN_LAYOUT: vk::ImageLayout = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;

/// Creates the twin of an image created with `info` and stored in `stored` (the float format
/// where revz promoted it), with its memory: in the application's format, or in the stored
/// one where the device refuses that (a UNORM format without transfer writes); `None`
/// (nothing left behind) where the device refuses both.
///
/// # Safety
/// `device` is live; `info` is the application's valid create info.
pub unsafe fn create(
    device: &DeviceState,
    info: &vk::ImageCreateInfo<'_>,
    stored: vk::Format,
) -> Option<ReadTwin> {
    // SAFETY: the caller's contract.
    unsafe { create_in(device, info, info.format) }.or_else(|| {
        // SAFETY: as above.
        (stored != info.format)
            .then(|| unsafe { create_in(device, info, stored) })
            .flatten()
    })
}

/// [`create`] in `format` (single-sampled twins; a multisampled twin is `R32_SFLOAT`).
///
/// # Safety
/// As [`create`].
unsafe fn create_in(
    device: &DeviceState,
    info: &vk::ImageCreateInfo<'_>,
    format: vk::Format,
) -> Option<ReadTwin> {
    let v = device.next.fp_v1_0();
    let null = std::ptr::null();
    // The flags views need (cube and 2D-array views of the image); the rest concern memory
    // the application places, or formats the twin does not have.
    let flags = info.flags
        & (vk::ImageCreateFlags::CUBE_COMPATIBLE | vk::ImageCreateFlags::TYPE_2D_ARRAY_COMPATIBLE);
    let multisampled = info.samples != vk::SampleCountFlags::TYPE_1;
    let twin_info = vk::ImageCreateInfo {
        p_next: std::ptr::null(),
        flags: if multisampled {
            vk::ImageCreateFlags::empty()
        } else {
            flags
        },
        format: if multisampled {
            MULTISAMPLED_FORMAT
        } else {
            format
        },
        usage: if multisampled {
            vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::STORAGE
        } else {
            vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST
        },
        initial_layout: vk::ImageLayout::UNDEFINED,
        ..*info
    };
    // The device must allow a single-sampled twin's format with the twin's usage (a UNORM
    // depth format without transfer writes would not); a multisampled twin's format and usage
    // were asked for at device creation (`DevicePolicy::multisampled_twin_samples`).
    if !multisampled && !device.image_formats.supports(&twin_info, twin_info.format) {
        return None;
    }
    let mut image = vk::Image::null();
    // SAFETY: a valid create info (the application's, narrowed) and output.
    if unsafe { (v.create_image)(device.handle, &twin_info, null, &mut image) }
        != vk::Result::SUCCESS
    {
        return None;
    }
    let mut requirements = vk::MemoryRequirements::default();
    // SAFETY: the image just created.
    unsafe { (v.get_image_memory_requirements)(device.handle, image, &mut requirements) };
    // SAFETY: a live device.
    let memory = match unsafe { super::scratch::allocate(device, requirements) } {
        Ok(memory) => memory,
        Err(_) => {
            // SAFETY: revz's image, never used.
            unsafe { (v.destroy_image)(device.handle, image, null) };
            return None;
        }
    };
    // SAFETY: fresh image and memory of an allowed type and its size.
    if unsafe { (v.bind_image_memory)(device.handle, image, memory, 0) } != vk::Result::SUCCESS {
        // SAFETY: revz's objects, never used.
        unsafe {
            (v.destroy_image)(device.handle, image, null);
            (v.free_memory)(device.handle, memory, null);
        }
        return None;
    }
    let image_aspects = crate::conv::aspects_of(format);
    Some(ReadTwin {
        image,
        memory,
        format: twin_info.format,
        extent: info.extent,
        mip_levels: info.mip_levels,
        array_layers: info.array_layers,
        aspects: if multisampled {
            vk::ImageAspectFlags::DEPTH
        } else {
            image_aspects
        },
        image_aspects,
        samples: info.samples,
    })
}

/// The format of a multisampled twin: depth in the first component, as shaders read a depth
/// image.
pub const MULTISAMPLED_FORMAT: vk::Format = vk::Format::R32_SFLOAT;

/// Creates what the refresh of a multisampled twin binds, for `image` (its memory bound: the
/// application makes views only then) stored in `format`. `None` (nothing left behind) where
/// the device refuses; the twin is then never refreshed (logged by the caller).
///
/// # Safety
/// `device` is live; `image` is the application's image of `twin`, bound to its memory.
pub unsafe fn create_multisampled_bindings(
    device: &DeviceState,
    image: vk::Image,
    format: vk::Format,
    twin: &ReadTwin,
) -> Option<MultisampledBindings> {
    let multisampled = device.copies.multisampled(device.handle, &device.next)?;
    let v = device.next.fp_v1_0();
    let null = std::ptr::null();
    let mut made = MultisampledBindings {
        pool: vk::DescriptorPool::null(),
        set: vk::DescriptorSet::null(),
        depth_view: vk::ImageView::null(),
        twin_view: vk::ImageView::null(),
    };
    let layers = |aspect_mask| vk::ImageSubresourceRange {
        aspect_mask,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: twin.array_layers,
    };
    let result = (|| {
        let depth_info = vk::ImageViewCreateInfo::default()
            .image(image)
            .view_type(vk::ImageViewType::TYPE_2D_ARRAY)
            .format(format)
            .subresource_range(layers(vk::ImageAspectFlags::DEPTH));
        // SAFETY: valid create infos and outputs (here and below); the image has memory.
        unsafe { (v.create_image_view)(device.handle, &depth_info, null, &mut made.depth_view) }
            .result()?;
        let twin_info = vk::ImageViewCreateInfo {
            image: twin.image,
            format: MULTISAMPLED_FORMAT,
            subresource_range: layers(vk::ImageAspectFlags::COLOR),
            ..depth_info
        };
        // SAFETY: as above.
        unsafe { (v.create_image_view)(device.handle, &twin_info, null, &mut made.twin_view) }
            .result()?;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLED_IMAGE,
                descriptor_count: 1,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_IMAGE,
                descriptor_count: 1,
            },
        ];
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: as above.
        unsafe { (v.create_descriptor_pool)(device.handle, &pool_info, null, &mut made.pool) }
            .result()?;
        let set_layouts = [multisampled.set_layout];
        let allocate = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(made.pool)
            .set_layouts(&set_layouts);
        // SAFETY: as above.
        unsafe { (v.allocate_descriptor_sets)(device.handle, &allocate, &mut made.set) }
            .result()?;
        let depth = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: made.depth_view,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        }];
        let storage = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: made.twin_view,
            image_layout: vk::ImageLayout::GENERAL,
        }];
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_set(made.set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                .image_info(&depth),
            vk::WriteDescriptorSet::default()
                .dst_set(made.set)
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                .image_info(&storage),
        ];
        // SAFETY: revz's own set, views and layout, never in use yet.
        unsafe {
            (v.update_descriptor_sets)(device.handle, 2, writes.as_ptr(), 0, std::ptr::null());
        }
        Ok::<(), vk::Result>(())
    })();
    match result {
        Ok(()) => Some(made),
        Err(_) => {
            // SAFETY: revz's own objects, never used (null handles are ignored).
            unsafe { destroy_multisampled_bindings(device, &made) };
            None
        }
    }
}

/// Destroys what [`create_multisampled_bindings`] made.
///
/// # Safety
/// No pending command buffer uses them (the application destroys its image only then).
pub unsafe fn destroy_multisampled_bindings(device: &DeviceState, made: &MultisampledBindings) {
    let v = device.next.fp_v1_0();
    let null = std::ptr::null();
    // SAFETY: the caller's contract; the pool frees its set.
    unsafe {
        (v.destroy_descriptor_pool)(device.handle, made.pool, null);
        (v.destroy_image_view)(device.handle, made.twin_view, null);
        (v.destroy_image_view)(device.handle, made.depth_view, null);
    }
}

/// Destroys a twin and frees its memory.
///
/// # Safety
/// No pending command buffer uses it (the application destroys its image only then).
pub unsafe fn destroy(device: &DeviceState, twin: &ReadTwin) {
    let v = device.next.fp_v1_0();
    // SAFETY: the caller's contract.
    unsafe {
        (v.destroy_image)(device.handle, twin.image, std::ptr::null());
        (v.free_memory)(device.handle, twin.memory, std::ptr::null());
    }
}

/// Creates the view of `twin` beside a view made with `info`: the same view of the twin in
/// the twin's format, without the application's extension structures (usage restrictions,
/// min LOD: the twin is only sampled); of a multisampled twin, in its color format (see
/// [`twin_reads`]: only views of the depth aspect get one).
///
/// # Safety
/// `device` is live; `info` is a valid create info of a view of the twin's image.
pub unsafe fn create_view(
    device: &DeviceState,
    info: &vk::ImageViewCreateInfo<'_>,
    twin: &ReadTwin,
) -> Option<vk::ImageView> {
    let twin_info = if twin.multisampled() {
        // Its depth, as the first component of the twin's color.
        vk::ImageViewCreateInfo {
            p_next: std::ptr::null(),
            image: twin.image,
            format: MULTISAMPLED_FORMAT,
            subresource_range: vk::ImageSubresourceRange {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                ..info.subresource_range
            },
            ..*info
        }
    } else {
        vk::ImageViewCreateInfo {
            p_next: std::ptr::null(),
            image: twin.image,
            format: twin.format,
            ..*info
        }
    };
    let mut view = vk::ImageView::null();
    // SAFETY: the caller's contract.
    let result = unsafe {
        (device.next.fp_v1_0().create_image_view)(
            device.handle,
            &twin_info,
            std::ptr::null(),
            &mut view,
        )
    };
    (result == vk::Result::SUCCESS).then_some(view)
}

/// Whether shaders read a view of `aspects` of the image of `twin` through the twin: every
/// view of a single-sampled twin's image; of a multisampled one's, views of its depth (its
/// stencil is read from the image itself).
pub fn twin_reads(twin: &ReadTwin, aspects: vk::ImageAspectFlags) -> bool {
    !twin.multisampled() || aspects.contains(vk::ImageAspectFlags::DEPTH)
}

/// A subresource range with its `VK_REMAINING_*` counts resolved against `twin`, and its
/// aspects narrowed to the twin's; `None` where it is empty.
pub fn resolved_range(
    range: vk::ImageSubresourceRange,
    twin: &ReadTwin,
) -> Option<vk::ImageSubresourceRange> {
    let resolve = |base: u32, count: u32, total: u32| {
        let left = total.checked_sub(base)?;
        let count = if count == vk::REMAINING_MIP_LEVELS {
            left
        } else {
            count.min(left)
        };
        (count > 0).then_some(count)
    };
    let aspects = range.aspect_mask & twin.aspects;
    if aspects.is_empty() {
        return None;
    }
    Some(vk::ImageSubresourceRange {
        aspect_mask: aspects,
        base_mip_level: range.base_mip_level,
        level_count: resolve(range.base_mip_level, range.level_count, twin.mip_levels)?,
        base_array_layer: range.base_array_layer,
        layer_count: resolve(range.base_array_layer, range.layer_count, twin.array_layers)?,
    })
}

/// What one refresh copies: the image, the layout the application left it in, and the
/// subresources.
#[derive(Clone, Copy, Debug)]
pub struct Refresh {
    pub image: vk::Image,
    pub layout: vk::ImageLayout,
    pub range: vk::ImageSubresourceRange,
    pub twin: ReadTwin,
    /// The texels of the stored format, and of the twin's (they differ where the image is
    /// promoted: float32 into UNORM).
    pub kinds: TexelKinds,
    /// The map to standard depth; `None` where the image holds standard depth already.
    pub map: Option<DepthMap>,
}

impl Refresh {
    /// The bytes it copies: every refreshed texel of the stored format's depth (and one byte
    /// of stencil each where it copies stencil too); of a multisampled twin, 4 bytes per
    /// sample of depth (it holds `R32_SFLOAT`; its stencil is not copied).
    pub fn bytes(&self) -> u64 {
        if self.twin.multisampled() {
            let extent = self.twin.extent;
            return u64::from(extent.width)
                * u64::from(extent.height)
                * u64::from(self.range.layer_count)
                * u64::from(self.twin.samples.as_raw())
                * 4;
        }
        let per_texel = |aspect| match aspect {
            vk::ImageAspectFlags::DEPTH => self.kinds.source.bytes(),
            _ => 1,
        };
        [vk::ImageAspectFlags::DEPTH, vk::ImageAspectFlags::STENCIL]
            .into_iter()
            .filter(|&aspect| self.range.aspect_mask.contains(aspect))
            .map(|aspect| {
                level_regions(&self.range, aspect, self.twin.extent)
                    .iter()
                    .map(|r| {
                        u64::from(r.extent.width)
                            * u64::from(r.extent.height)
                            * u64::from(r.extent.depth)
                            * u64::from(r.src_subresource.layer_count)
                            * per_texel(aspect)
                    })
                    .sum::<u64>()
            })
            .sum()
    }
}

/// The copy regions of `range`'s `aspect` at every mip level (the same subresource at both
/// ends, the level's size).
fn level_regions(
    range: &vk::ImageSubresourceRange,
    aspect: vk::ImageAspectFlags,
    extent: vk::Extent3D,
) -> Vec<vk::ImageCopy> {
    (range.base_mip_level..range.base_mip_level + range.level_count)
        .map(|level| {
            let subresource = vk::ImageSubresourceLayers {
                aspect_mask: aspect,
                mip_level: level,
                base_array_layer: range.base_array_layer,
                layer_count: range.layer_count,
            };
            let side = |size: u32| (size >> level).max(1);
            vk::ImageCopy {
                src_subresource: subresource,
                src_offset: vk::Offset3D::default(),
                dst_subresource: subresource,
                dst_offset: vk::Offset3D::default(),
                extent: vk::Extent3D {
                    width: side(extent.width),
                    height: side(extent.height),
                    depth: side(extent.depth),
                },
            }
        })
        .collect()
}

/// Records a refresh of `refresh.twin` from its image, with the barriers around it (see the
/// module's docs): `Ok(true)`, or `Ok(false)` where there is nothing to record yet (a
/// multisampled twin whose image has no view, so no shader can read it). On `Err` the barriers
/// are recorded all the same (layouts stay consistent) and the twin's refreshed subresources
/// are undefined.
///
/// # Safety
/// `buffer` is a command buffer of `device` in the recording state, outside a render pass,
/// and `copies` its scratch.
pub unsafe fn record_refresh(
    device: &DeviceState,
    copies: &mut CommandCopies,
    buffer: vk::CommandBuffer,
    refresh: &Refresh,
) -> Result<bool, Unconverted> {
    if refresh.twin.multisampled() {
        // SAFETY: the caller's contract.
        return unsafe { record_multisampled_refresh(device, copies, buffer, refresh) };
    }
    let v = device.next.fp_v1_0();
    let range = refresh.range;
    let twin_range = vk::ImageSubresourceRange {
        aspect_mask: refresh.twin.aspects,
        ..range
    };
    let image_barrier = |image, range, old, new, src_access, dst_access| {
        image_barrier(image, range, (old, new), (src_access, dst_access))
    };
    let barrier = |src_stage, dst_stage, barriers: &[vk::ImageMemoryBarrier<'_>]| {
        // SAFETY: a recording command buffer outside a render pass (the caller's contract);
        // the application's image in the layout it left it in, and revz's twin.
        unsafe { pipeline_barrier(device, buffer, (src_stage, dst_stage), &[], &[], barriers) }
    };
    let transfer = vk::PipelineStageFlags::TRANSFER;
    let all = vk::PipelineStageFlags::ALL_COMMANDS;
    barrier(
        all,
        transfer,
        &[
            image_barrier(
                refresh.image,
                range,
                refresh.layout,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                vk::AccessFlags::MEMORY_WRITE,
                vk::AccessFlags::TRANSFER_READ,
            ),
            image_barrier(
                refresh.twin.image,
                twin_range,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::AccessFlags::empty(),
                vk::AccessFlags::TRANSFER_WRITE,
            ),
        ],
    );
    let src_layout = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
    let dst_layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
    let copy = |regions: &[vk::ImageCopy]| {
        // SAFETY: the image and its twin have one format and size; both in transfer layouts.
        unsafe {
            (v.cmd_copy_image)(
                buffer,
                refresh.image,
                src_layout,
                refresh.twin.image,
                dst_layout,
                regions.len() as u32,
                regions.as_ptr(),
            )
        }
    };
    let mut convert = |regions: &[vk::ImageCopy], map| match plan_image_copy(regions, refresh.kinds)
    {
        None => Err(Unconverted::Regions),
        Some(plan) => {
            let conversion = Conversion {
                header: ShaderHeader::new(refresh.kinds, map, &plan.layout),
                size: plan.layout.size,
                fill: Fill::Image {
                    image: refresh.image,
                    layout: src_layout,
                    regions: &plan.from_source,
                },
                drain: Drain::Image {
                    image: refresh.twin.image,
                    layout: dst_layout,
                    regions: &plan.to_destination,
                },
            };
            // SAFETY: the caller's contract.
            unsafe { record(device, copies, buffer, &conversion) }
        }
    };
    let regions_of = |aspect| level_regions(&range, aspect, refresh.twin.extent);
    let (depth, stencil) = (vk::ImageAspectFlags::DEPTH, vk::ImageAspectFlags::STENCIL);
    let result = if refresh.kinds.source != refresh.kinds.destination {
        // A promoted image into its UNORM twin: both aspects through the conversion (no image
        // copy goes between two formats), the depth converted even where it is standard.
        let regions: Vec<vk::ImageCopy> = [depth, stencil]
            .into_iter()
            .filter(|&aspect| range.aspect_mask.contains(aspect))
            .flat_map(regions_of)
            .collect();
        convert(&regions, refresh.map.unwrap_or(DepthMap::IDENTITY))
    } else {
        // The stencil first: lavapipe (Mesa 22.3) copies the stencil aspect of a
        // D24_UNORM_S8_UINT or D32_SFLOAT_S8_UINT image as whole texels, depth included, so
        // the converted depth must be the last write (the conversion's own barriers order the
        // two transfers).
        if range.aspect_mask.contains(stencil) {
            copy(&regions_of(stencil));
        }
        match (range.aspect_mask.contains(depth), refresh.map) {
            (false, _) => Ok(()),
            (true, None) => {
                copy(&regions_of(depth));
                Ok(())
            }
            (true, Some(map)) => convert(&regions_of(depth), map),
        }
    };
    barrier(
        transfer,
        all,
        &[
            image_barrier(
                refresh.image,
                range,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                refresh.layout,
                vk::AccessFlags::empty(),
                vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE,
            ),
            image_barrier(
                refresh.twin.image,
                twin_range,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                TWIN_LAYOUT,
                vk::AccessFlags::TRANSFER_WRITE,
                vk::AccessFlags::SHADER_READ,
            ),
        ],
    );
    result.map(|()| true)
}

/// The first 16 bytes of the scratch buffer the refresh of a multisampled twin reads
/// (`depth_convert_ms.comp`'s `Header`): the map's scale and offset (float32), whether results
/// stay unclamped, and the first layer of the dispatch.
pub fn multisampled_header(map: Option<DepthMap>, base_layer: u32) -> [u8; 16] {
    let map = map.unwrap_or(DepthMap::IDENTITY);
    let words = [
        (map.scale as f32).to_bits(),
        (map.offset as f32).to_bits(),
        u32::from(!map.clamp),
        base_layer,
    ];
    let mut bytes = [0; 16];
    for (chunk, word) in bytes.chunks_exact_mut(4).zip(words) {
        chunk.copy_from_slice(&word.to_ne_bytes());
    }
    bytes
}

/// Records the refresh of a multisampled twin (the module's docs). Nothing where the image has
/// no view yet (so no shader can read it).
///
/// # Safety
/// As [`record_refresh`].
unsafe fn record_multisampled_refresh(
    device: &DeviceState,
    copies: &mut CommandCopies,
    buffer: vk::CommandBuffer,
    refresh: &Refresh,
) -> Result<bool, Unconverted> {
    let Some(bindings) = device.objects.multisampled_twins.get(&refresh.image) else {
        return Ok(false);
    };
    let convert = device
        .copies
        .multisampled(device.handle, &device.next)
        .ok_or(Unconverted::Resources)?;
    let slot = copies.slot(device, 16).ok_or(Unconverted::Resources)?;
    let (scratch, scratch_set) = (slot.buffer, slot.set);
    let v = device.next.fp_v1_0();
    let layers = |aspect_mask| vk::ImageSubresourceRange {
        aspect_mask,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: refresh.range.base_array_layer,
        layer_count: refresh.range.layer_count,
    };
    let image_range = layers(refresh.twin.image_aspects);
    let twin_range = layers(vk::ImageAspectFlags::COLOR);
    let read = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
    let transfer = vk::PipelineStageFlags::TRANSFER;
    let compute = vk::PipelineStageFlags::COMPUTE_SHADER;
    let all = vk::PipelineStageFlags::ALL_COMMANDS;
    // Everything before (the application's writes of the image, earlier uses of the scratch
    // buffer) before the header's write and the dispatch.
    let before = vk::MemoryBarrier {
        src_access_mask: vk::AccessFlags::MEMORY_WRITE,
        dst_access_mask: vk::AccessFlags::TRANSFER_WRITE | vk::AccessFlags::SHADER_READ,
        ..Default::default()
    };
    // SAFETY: a recording command buffer outside a render pass (the caller's contract), the
    // application's image in the layout it left it in, and revz's twin, scratch buffer,
    // pipeline and sets (every call in this block).
    unsafe {
        pipeline_barrier(
            device,
            buffer,
            (all, transfer | compute),
            &[before],
            &[],
            &[
                image_barrier(
                    refresh.image,
                    image_range,
                    (refresh.layout, read),
                    (vk::AccessFlags::MEMORY_WRITE, vk::AccessFlags::SHADER_READ),
                ),
                image_barrier(
                    refresh.twin.image,
                    twin_range,
                    (vk::ImageLayout::UNDEFINED, vk::ImageLayout::GENERAL),
                    (vk::AccessFlags::empty(), vk::AccessFlags::SHADER_WRITE),
                ),
            ],
        );
        let header = multisampled_header(refresh.map, refresh.range.base_array_layer);
        (v.cmd_update_buffer)(buffer, scratch, 0, 16, header.as_ptr().cast());
        let written = vk::BufferMemoryBarrier {
            src_access_mask: vk::AccessFlags::TRANSFER_WRITE,
            dst_access_mask: vk::AccessFlags::SHADER_READ,
            src_queue_family_index: vk::QUEUE_FAMILY_IGNORED,
            dst_queue_family_index: vk::QUEUE_FAMILY_IGNORED,
            buffer: scratch,
            offset: 0,
            size: vk::WHOLE_SIZE,
            ..Default::default()
        };
        pipeline_barrier(device, buffer, (transfer, compute), &[], &[written], &[]);
        (v.cmd_bind_pipeline)(buffer, vk::PipelineBindPoint::COMPUTE, convert.pipeline);
        let sets = [scratch_set, bindings.set];
        (v.cmd_bind_descriptor_sets)(
            buffer,
            vk::PipelineBindPoint::COMPUTE,
            convert.layout,
            0,
            sets.len() as u32,
            sets.as_ptr(),
            0,
            std::ptr::null(),
        );
        let groups = |size: u32| size.div_ceil(8);
        (v.cmd_dispatch)(
            buffer,
            groups(refresh.twin.extent.width),
            groups(refresh.twin.extent.height),
            refresh.range.layer_count,
        );
        pipeline_barrier(
            device,
            buffer,
            (compute, all),
            &[],
            &[],
            &[
                image_barrier(
                    refresh.image,
                    image_range,
                    (read, refresh.layout),
                    (
                        vk::AccessFlags::empty(),
                        vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE,
                    ),
                ),
                image_barrier(
                    refresh.twin.image,
                    twin_range,
                    (vk::ImageLayout::GENERAL, TWIN_LAYOUT),
                    (vk::AccessFlags::SHADER_WRITE, vk::AccessFlags::SHADER_READ),
                ),
            ],
        );
        copies.compute.restore(device, buffer);
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::depth_copy::plan::TexelKind;
    use ash::vk::Handle;

    #[test]
    fn a_multisampled_refresh_counts_four_bytes_per_sample() {
        let twin = ReadTwin {
            aspects: vk::ImageAspectFlags::DEPTH,
            mip_levels: 1,
            samples: vk::SampleCountFlags::TYPE_4,
            ..twin()
        };
        let refresh = Refresh {
            image: vk::Image::from_raw(3),
            layout: TWIN_LAYOUT,
            range: vk::ImageSubresourceRange {
                aspect_mask: vk::ImageAspectFlags::DEPTH,
                base_mip_level: 0,
                level_count: 1,
                base_array_layer: 1,
                layer_count: 2,
            },
            twin,
            kinds: TexelKinds {
                source: TexelKind::Float32,
                destination: TexelKind::Float32,
            },
            map: None,
        };
        assert_eq!(refresh.bytes(), 64 * 32 * 2 * 4 * 4);
    }

    #[test]
    fn the_multisampled_header_holds_the_map_in_float32() {
        let words = |bytes: [u8; 16]| -> [u32; 4] {
            std::array::from_fn(|i| u32::from_ne_bytes(bytes[4 * i..4 * i + 4].try_into().unwrap()))
        };
        let flip = words(multisampled_header(
            Some(DepthMap::to_standard(crate::conv::Reversal::Complementary)),
            3,
        ));
        assert_eq!(flip, [(-1.0f32).to_bits(), 1.0f32.to_bits(), 0, 3]);
        // Standard depth already: copied as it is.
        assert_eq!(
            words(multisampled_header(None, 0)),
            [1.0f32.to_bits(), 0, 0, 0]
        );
        let unclamped =
            DepthMap::to_standard(crate::conv::Reversal::Complementary).unrestricted(true);
        assert_eq!(words(multisampled_header(Some(unclamped), 0))[2], 1);
    }

    fn twin() -> ReadTwin {
        ReadTwin {
            image: vk::Image::from_raw(1),
            memory: vk::DeviceMemory::from_raw(2),
            format: vk::Format::D24_UNORM_S8_UINT,
            extent: vk::Extent3D {
                width: 64,
                height: 32,
                depth: 1,
            },
            mip_levels: 4,
            array_layers: 6,
            aspects: vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
            image_aspects: vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
            samples: vk::SampleCountFlags::TYPE_1,
        }
    }

    #[test]
    fn ranges_resolve_remaining_counts_and_keep_the_twins_aspects() {
        let range = vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::COLOR,
            base_mip_level: 1,
            level_count: vk::REMAINING_MIP_LEVELS,
            base_array_layer: 2,
            layer_count: vk::REMAINING_ARRAY_LAYERS,
        };
        let resolved = resolved_range(range, &twin()).unwrap();
        assert_eq!(resolved.aspect_mask, vk::ImageAspectFlags::DEPTH);
        assert_eq!((resolved.level_count, resolved.layer_count), (3, 4));
        let past = vk::ImageSubresourceRange {
            base_mip_level: 4,
            ..range
        };
        assert!(resolved_range(past, &twin()).is_none());
        let color = vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            ..range
        };
        assert!(resolved_range(color, &twin()).is_none());
    }

    #[test]
    fn each_level_is_copied_at_its_own_size() {
        let range = vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::DEPTH,
            base_mip_level: 1,
            level_count: 3,
            base_array_layer: 0,
            layer_count: 6,
        };
        let regions = level_regions(&range, vk::ImageAspectFlags::STENCIL, twin().extent);
        let sizes: Vec<_> = regions
            .iter()
            .map(|r| (r.src_subresource.mip_level, r.extent.width, r.extent.height))
            .collect();
        assert_eq!(sizes, [(1, 32, 16), (2, 16, 8), (3, 8, 4)]);
        assert!(regions.iter().all(|r| {
            let (s, d) = (r.src_subresource, r.dst_subresource);
            (s.mip_level, s.base_array_layer, s.layer_count)
                == (d.mip_level, d.base_array_layer, d.layer_count)
                && s.aspect_mask == vk::ImageAspectFlags::STENCIL
                && s.layer_count == 6
        }));
    }
}
