//! Object-tracking hooks: depth images and their views, render passes, framebuffers, and
//! command buffer allocation. Each records what was created only when the driver succeeded.
//! The one change made to what the application passes: a depth image the policy promotes
//! (`crate::policy::DevicePolicy::promoted_format`) is created, and viewed, in its float
//! format; the application then allocates and binds the memory the driver asks for it.

use std::sync::{Arc, Mutex};

use ash::vk;

use super::{device_state, record};
use crate::boundary::{guarded, EntryPoint};
use crate::objects::{self, ImageInfo};
use crate::policy::{may_be_resolved, promoted_view_format, ImageDepth, ImageFacts};
use crate::state::DeviceState;

static CREATE_IMAGE: EntryPoint = EntryPoint::new("vkCreateImage");
static DESTROY_IMAGE: EntryPoint = EntryPoint::new("vkDestroyImage");
static CREATE_IMAGE_VIEW: EntryPoint = EntryPoint::new("vkCreateImageView");
static DESTROY_IMAGE_VIEW: EntryPoint = EntryPoint::new("vkDestroyImageView");
static ALLOCATE_COMMAND_BUFFERS: EntryPoint = EntryPoint::new("vkAllocateCommandBuffers");
static FREE_COMMAND_BUFFERS: EntryPoint = EntryPoint::new("vkFreeCommandBuffers");
static DESTROY_COMMAND_POOL: EntryPoint = EntryPoint::new("vkDestroyCommandPool");
static CREATE_COMMAND_POOL: EntryPoint = EntryPoint::new("vkCreateCommandPool");
static CREATE_DESCRIPTOR_UPDATE_TEMPLATE: EntryPoint =
    EntryPoint::new("vkCreateDescriptorUpdateTemplate");
static DESTROY_DESCRIPTOR_UPDATE_TEMPLATE: EntryPoint =
    EntryPoint::new("vkDestroyDescriptorUpdateTemplate");

/// What revz creates a depth image as: its own create info, or a promoted copy
/// (`crate::policy::DevicePolicy::promoted_format`), with the copies it points into.
struct ImageCreation<'a> {
    info: vk::ImageCreateInfo<'a>,
    /// The float format, where promoted.
    promoted: Option<vk::Format>,
    /// The image gets a read twin (`crate::policy::DevicePolicy::reads_through_twin`): it is
    /// created with `TRANSFER_SRC` usage too, which its refreshes copy from.
    twin: bool,
    /// The spliced chain (a format list with the float format) and the list it points at.
    _chain: Option<(crate::chain::Spliced, Vec<vk::Format>)>,
}

/// Logs once per reason why images keep their UNORM format.
fn log_kept_format(format: vk::Format, reason: crate::policy::KeptFormat) {
    use crate::policy::KeptFormat;
    static ONCE: [crate::logging::LogOnce; 10] = [const { crate::logging::LogOnce::new() }; 10];
    let index = match reason {
        KeptFormat::HostCopied => 0,
        KeptFormat::LaidOutOutside => 1,
        KeptFormat::PlacedMemory => 2,
        KeptFormat::Unsupported => 3,
        KeptFormat::ResolvePartner => 4,
        KeptFormat::FormatListFixed => 5,
        KeptFormat::CopiedUnobserved => 6,
        KeptFormat::UnrestrictedDepthRange => 7,
        KeptFormat::NotAnAttachment => 8,
        KeptFormat::DescriptorHeap => 9,
    };
    ONCE[index].log(|| {
        log::info!("depth images such as one in {format:?} keep their format, because {reason}")
    });
}

/// Plans the creation of an image: promoted where the policy says so and its chain can be
/// followed, and with the usage its read twin's refreshes need where it gets one.
///
/// # Safety
/// `info` is the application's valid create info.
unsafe fn plan_image<'a>(state: &DeviceState, info: &vk::ImageCreateInfo<'a>) -> ImageCreation<'a> {
    // SAFETY: the caller's contract.
    let mut creation = unsafe { plan_promotion(state, info) };
    let twin = state
        .policy
        .classify_image(info.format, info.usage, info.tiling, info.samples)
        == Some(ImageDepth::Reversed)
        && state
            .policy
            .reads_through_twin(info.usage, info.samples, info.tiling);
    if twin {
        let with_source = vk::ImageCreateInfo {
            usage: creation.info.usage | vk::ImageUsageFlags::TRANSFER_SRC,
            ..creation.info
        };
        // The device must allow the image with the added usage (it nearly always does).
        if info.usage.contains(vk::ImageUsageFlags::TRANSFER_SRC)
            || state
                .image_formats
                .supports(&with_source, with_source.format)
        {
            creation.info = with_source;
            creation.twin = true;
        }
    }
    creation
}

/// The promotion part of [`plan_image`].
///
/// # Safety
/// `info` is the application's valid create info.
unsafe fn plan_promotion<'a>(
    state: &DeviceState,
    info: &vk::ImageCreateInfo<'a>,
) -> ImageCreation<'a> {
    let unchanged = ImageCreation {
        info: *info,
        promoted: None,
        twin: false,
        _chain: None,
    };
    if !state.policy.may_promote(info.format) {
        return unchanged;
    }
    // SAFETY: a valid chain (the application's contract).
    let external = unsafe {
        crate::chain::find::<vk::ExternalMemoryImageCreateInfo<'_>>(info.p_next)
            .is_some_and(|external| !external.handle_types.is_empty())
    };
    let facts = ImageFacts {
        usage: info.usage,
        tiling: info.tiling,
        flags: info.flags,
        external,
        partner_kept: may_be_resolved(info.usage)
            && state
                .objects
                .resolve_partner_kept(info.format, info.extent, info.samples),
        // SAFETY: as above.
        format_list_fixed: unsafe {
            crate::chain::splice_blocked::<vk::ImageFormatListCreateInfo<'_>>(info.p_next)
        },
    };
    let promoted = state.policy.promoted_format(info.format, facts, |float| {
        state.image_formats.supports(info, float)
    });
    let float = match promoted {
        Ok(Some(float)) => float,
        Ok(None) => return unchanged,
        Err(reason) => {
            log_kept_format(info.format, reason);
            return unchanged;
        }
    };
    // A format list naming the UNORM format names the float one instead.
    // SAFETY: as above.
    let list = unsafe { crate::chain::find::<vk::ImageFormatListCreateInfo<'_>>(info.p_next) };
    let chain = match list {
        Some(list) => {
            // SAFETY: `viewFormatCount` formats.
            let formats: Vec<vk::Format> =
                unsafe { slice(list.p_view_formats, list.view_format_count) }
                    .iter()
                    .map(|&f| promoted_view_format(f, info.format, Some(float)).unwrap_or(f))
                    .collect();
            let replacement = vk::ImageFormatListCreateInfo {
                view_format_count: formats.len() as u32,
                p_view_formats: formats.as_ptr(),
                ..*list
            };
            // SAFETY: as above; `formats` lives as long as the splice (moved beside it; its
            // buffer does not move).
            let spliced = unsafe { crate::chain::splice(info.p_next, Some(&replacement)) };
            // Always spliced: the policy keeps the format of an image whose list cannot be
            // (`ImageFacts::format_list_fixed`).
            match spliced {
                Some(spliced) => Some((spliced, formats)),
                None => return unchanged,
            }
        }
        None => None,
    };
    let p_next = chain
        .as_ref()
        .map_or(info.p_next, |(spliced, _)| spliced.head());
    ImageCreation {
        info: vk::ImageCreateInfo {
            format: float,
            p_next,
            ..*info
        },
        promoted: Some(float),
        twin: false,
        _chain: chain,
    }
}

/// The bytes a promoted image adds to its UNORM layout (texel sizes as copies count them,
/// over every mip level, layer and sample).
fn promotion_cost(info: &vk::ImageCreateInfo<'_>, float: vk::Format) -> u64 {
    let extra = crate::conv::depth_texel_bytes(float)
        .saturating_sub(crate::conv::depth_texel_bytes(info.format));
    let texels: u64 = (0..info.mip_levels.min(32))
        .map(|level| {
            let side = |size: u32| u64::from((size >> level).max(1));
            side(info.extent.width) * side(info.extent.height) * side(info.extent.depth)
        })
        .sum();
    extra * texels * u64::from(info.array_layers) * u64::from(info.samples.as_raw().max(1))
}

pub unsafe extern "system" fn create_image(
    device: vk::Device,
    p_create_info: *const vk::ImageCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_image: *mut vk::Image,
) -> vk::Result {
    // SAFETY: `device` is live (caller's contract).
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    let creation = guarded(
        &CREATE_IMAGE,
        // SAFETY: the application's valid create info.
        || Some(unsafe { plan_image(&state, &*p_create_info) }),
        || None,
    );
    // Unchanged images go down with the application's own pointer.
    let info_down = creation
        .as_ref()
        .filter(|creation| creation.promoted.is_some() || creation.twin)
        .map_or(p_create_info, |creation| &creation.info as *const _);
    // SAFETY: calling down with the application's arguments, or its create info with the
    // float format.
    let result =
        unsafe { (state.next.fp_v1_0().create_image)(device, info_down, p_allocator, p_image) };
    if result == vk::Result::SUCCESS {
        record(&CREATE_IMAGE, || {
            // SAFETY: valid on success.
            let (info, image) = unsafe { (&*p_create_info, *p_image) };
            let Some(mut depth) =
                state
                    .policy
                    .classify_image(info.format, info.usage, info.tiling, info.samples)
            else {
                return;
            };
            let size = info.extent;
            let format = info.format;
            let promoted = creation.as_ref().and_then(|creation| creation.promoted);
            // Shaders read a reversed image they sample through its read twin.
            let mut twin = None;
            let twin_planned = creation.as_ref().is_some_and(|creation| creation.twin);
            if depth == ImageDepth::Reversed
                && state
                    .policy
                    .reads_through_twin(info.usage, info.samples, info.tiling)
            {
                // The image was created with the usage its refreshes need where the twin was
                // planned (`plan_image`); else it has none, and stays native.
                twin = if twin_planned {
                    // SAFETY: a live device and the application's valid create info.
                    unsafe {
                        crate::depth_copy::twin::create(&state, info, promoted.unwrap_or(format))
                    }
                } else {
                    None
                };
                match twin {
                    Some(_) => {
                        state
                            .objects
                            .twins
                            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    }
                    None => {
                        log::warn!(
                            "cannot create the read twin of depth image {image:?}: it stays \
                             native"
                        );
                        depth = ImageDepth::Native(crate::policy::NativeReason::ReadByShaders(
                            info.usage & vk::ImageUsageFlags::SAMPLED,
                        ));
                    }
                }
            }
            // Infinite mode: an image read as an input attachment stores complementary depth.
            let complementary =
                depth == ImageDepth::Reversed && state.policy.stores_complementary(info.usage);
            let read_twin = match (twin.is_some(), complementary) {
                (true, true) => {
                    ", shaders read its twin; stores complementary depth (read as an input \
                     attachment)"
                }
                (true, false) => ", shaders read its twin",
                (false, true) => ", stores complementary depth (read as an input attachment)",
                (false, false) => "",
            };
            let promotion = match promoted {
                Some(float) => format!(
                    "promoted to {float:?} ({} more bytes)",
                    promotion_cost(info, float)
                ),
                None => String::new(),
            };
            match (depth, promoted) {
                (ImageDepth::Reversed, None) => log::info!(
                    "depth image {image:?} ({format:?}, {}x{}): reversed{read_twin}",
                    size.width,
                    size.height
                ),
                (ImageDepth::Reversed, Some(_)) => log::info!(
                    "depth image {image:?} ({format:?}, {}x{}): reversed, {promotion}{read_twin}",
                    size.width,
                    size.height
                ),
                (ImageDepth::Native(reason), None) => log::info!(
                    "depth image {image:?} ({format:?}, {}x{}): native, because {reason}",
                    size.width,
                    size.height
                ),
                (ImageDepth::Native(reason), Some(_)) => log::info!(
                    "depth image {image:?} ({format:?}, {}x{}): native, because {reason}; \
                     {promotion}",
                    size.width,
                    size.height
                ),
            }
            if let Some(profile) = &state.profile {
                profile.image(
                    image,
                    crate::profile::ImageRecord {
                        format,
                        promoted,
                        extent: info.extent,
                        samples: info.samples,
                        usage: info.usage,
                        native_because: match depth {
                            ImageDepth::Reversed => None,
                            ImageDepth::Native(reason) => Some(reason.to_string()),
                        },
                        demoted_in_frame: None,
                        read_twin: twin.is_some(),
                    },
                );
            }
            // A handle the driver reuses starts with no camera (a pass into the destroyed
            // image may have remembered one after its destroy was recorded).
            state.objects.near_over_far.remove(&image);
            if complementary {
                state.objects.complementary_images.insert(image, ());
            } else {
                state.objects.complementary_images.remove(&image);
            }
            state.objects.images.insert(
                image,
                ImageInfo {
                    format,
                    depth,
                    promoted,
                    extent: info.extent,
                    samples: info.samples,
                    array_layers: info.array_layers,
                    twin,
                },
            );
        });
    }
    result
}

/// `vkGetDeviceImageMemoryRequirements`: the application asks what an image it has not
/// created yet needs; revz answers for the image it would create (its float format where
/// promoted), so that the memory the application allocates fits it.
pub unsafe extern "system" fn get_device_image_memory_requirements(
    device: vk::Device,
    p_info: *const vk::DeviceImageMemoryRequirements<'_>,
    p_requirements: *mut vk::MemoryRequirements2<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkGetDeviceImageMemoryRequirements");
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    let Some(next) = state.commands.get_device_image_memory_requirements else {
        return;
    };
    let creation = guarded(
        &ENTRY,
        || {
            // SAFETY: a valid query (the application's contract).
            let info = unsafe { (*p_info).p_create_info.as_ref() }?;
            // SAFETY: as above.
            let creation = unsafe { plan_image(&state, info) };
            (creation.promoted.is_some() || creation.twin).then_some(creation)
        },
        || None,
    );
    let query;
    let p_info = match &creation {
        Some(creation) => {
            query = vk::DeviceImageMemoryRequirements {
                p_create_info: &creation.info,
                // SAFETY: as above.
                ..unsafe { *p_info }
            };
            &query as *const _
        }
        None => p_info,
    };
    // SAFETY: calling down with the application's arguments (its create info with the
    // float format where revz would promote the image).
    unsafe { next(device, p_info, p_requirements) }
}

pub unsafe extern "system" fn create_image_view(
    device: vk::Device,
    p_create_info: *const vk::ImageViewCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_view: *mut vk::ImageView,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // A view of a promoted image in the image's UNORM format is made in its float format
    // (the only format a depth image's views can have).
    let promoted = guarded(
        &CREATE_IMAGE_VIEW,
        || {
            // SAFETY: the application's valid create info.
            let info = unsafe { &*p_create_info };
            let image = state.objects.images.get(&info.image)?;
            let float = promoted_view_format(info.format, image.format, image.promoted)?;
            Some(vk::ImageViewCreateInfo {
                format: float,
                ..*info
            })
        },
        || None,
    );
    let info_down = promoted
        .as_ref()
        .map_or(p_create_info, |info| info as *const _);
    // SAFETY: calling down with the application's arguments (or its create info with the
    // promoted image's format).
    let result =
        unsafe { (state.next.fp_v1_0().create_image_view)(device, info_down, p_allocator, p_view) };
    if result == vk::Result::SUCCESS {
        record(&CREATE_IMAGE_VIEW, || {
            // SAFETY: valid on success.
            let (info, view) = unsafe { (&*p_create_info, *p_view) };
            let Some(image) = state.objects.images.get(&info.image) else {
                return;
            };
            state.objects.views.insert(view, info.image);
            if let Some(twin) = image.twin.filter(|twin| twin.multisampled()) {
                // The refresh of a multisampled twin reads the image through a view of revz's
                // own, made at the image's first view (its memory is bound by then).
                if state.objects.multisampled_twins.get(&info.image).is_none() {
                    let stored = image.promoted.unwrap_or(image.format);
                    // SAFETY: the application's live image, bound to memory, and its twin.
                    let made = unsafe {
                        crate::depth_copy::twin::create_multisampled_bindings(
                            &state, info.image, stored, &twin,
                        )
                    };
                    match made {
                        Some(made) => state.objects.multisampled_twins.insert(info.image, made),
                        None => log::warn!(
                            "cannot make the refresh of the read twin of multisampled depth \
                             image {:?}: shaders reading it read what its twin last held",
                            info.image
                        ),
                    }
                }
            }
            if let Some(twin) = image.twin.as_ref().filter(|twin| {
                crate::depth_copy::twin::twin_reads(twin, info.subresource_range.aspect_mask)
            }) {
                // SAFETY: the create info the view was made with, of the twin's image.
                let made =
                    unsafe { crate::depth_copy::twin::create_view(&state, &*info_down, twin) };
                match made {
                    Some(twin_view) => state.objects.twin_views.insert(
                        view,
                        crate::objects::TwinView {
                            view: twin_view,
                            image: info.image,
                            range: info.subresource_range,
                        },
                    ),
                    None => log::warn!(
                        "cannot create a view of the read twin of depth image {:?}: shaders \
                         reading view {view:?} read reversed depth",
                        info.image
                    ),
                }
            }
        });
    }
    result
}

/// A slice from a Vulkan array pointer; empty for a null pointer or zero count.
///
/// # Safety
/// A non-null `ptr` must point at `count` valid elements.
pub(crate) unsafe fn slice<'a, T>(ptr: *const T, count: u32) -> &'a [T] {
    if ptr.is_null() || count == 0 {
        &[]
    } else {
        // SAFETY: the caller guarantees `count` elements.
        unsafe { std::slice::from_raw_parts(ptr, count as usize) }
    }
}

/// `vkDestroyImage`: a destroyed image's handle may come back: its resolve pairs go with it,
/// and its read twin is destroyed (no pending command uses the image, so none uses the twin).
pub unsafe extern "system" fn destroy_image(
    device: vk::Device,
    image: vk::Image,
    p_allocator: *const vk::AllocationCallbacks<'_>,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    record(&DESTROY_IMAGE, || {
        let info = state.objects.images.remove(&image);
        state.objects.near_over_far.remove(&image);
        state.objects.complementary_images.remove(&image);
        state.objects.resolve_pairs.remove(&image);
        if let Some(made) = state.objects.multisampled_twins.remove(&image) {
            // SAFETY: revz's objects; no pending command uses the image, so none uses them.
            unsafe { crate::depth_copy::twin::destroy_multisampled_bindings(&state, &made) };
        }
        if let Some(twin) = info.and_then(|info| info.twin) {
            // SAFETY: as above.
            unsafe { crate::depth_copy::twin::destroy(&state, &twin) };
            state
                .objects
                .twins
                .fetch_sub(1, std::sync::atomic::Ordering::Relaxed);
        }
    });
    // SAFETY: calling down with the application's arguments.
    unsafe { (state.next.fp_v1_0().destroy_image)(device, image, p_allocator) };
}

/// `vkDestroyImageView`: the view of the read twin made beside it goes with it.
pub unsafe extern "system" fn destroy_image_view(
    device: vk::Device,
    view: vk::ImageView,
    p_allocator: *const vk::AllocationCallbacks<'_>,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    record(&DESTROY_IMAGE_VIEW, || {
        state.objects.views.remove(&view);
        if let Some(twin_view) = state.objects.twin_views.remove(&view) {
            // SAFETY: revz's view; no pending command uses the application's view, whose
            // descriptors are the only ones that named it.
            unsafe {
                (state.next.fp_v1_0().destroy_image_view)(device, twin_view.view, std::ptr::null())
            };
        }
    });
    // SAFETY: calling down with the application's arguments.
    unsafe { (state.next.fp_v1_0().destroy_image_view)(device, view, p_allocator) };
}
pub unsafe extern "system" fn allocate_command_buffers(
    device: vk::Device,
    p_allocate_info: *const vk::CommandBufferAllocateInfo<'_>,
    p_command_buffers: *mut vk::CommandBuffer,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result = unsafe {
        (state.next.fp_v1_0().allocate_command_buffers)(device, p_allocate_info, p_command_buffers)
    };
    if result == vk::Result::SUCCESS {
        record(&ALLOCATE_COMMAND_BUFFERS, || {
            // SAFETY: valid on success: `commandBufferCount` handles were written.
            let info = unsafe { &*p_allocate_info };
            // SAFETY: as above.
            let buffers = unsafe { slice(p_command_buffers, info.command_buffer_count) };
            objects::track_command_buffers(&state, buffers, info.level, info.command_pool);
            let pool = state
                .objects
                .pools
                .get(&info.command_pool)
                .unwrap_or_else(|| {
                    let list = Arc::new(Mutex::new(Vec::new()));
                    state
                        .objects
                        .pools
                        .insert(info.command_pool, Arc::clone(&list));
                    list
                });
            pool.lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .extend_from_slice(buffers);
        });
    }
    result
}

pub unsafe extern "system" fn free_command_buffers(
    device: vk::Device,
    command_pool: vk::CommandPool,
    count: u32,
    p_command_buffers: *const vk::CommandBuffer,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    record(&FREE_COMMAND_BUFFERS, || {
        // SAFETY: `count` handles (null entries are allowed and ignored).
        let buffers = unsafe { slice(p_command_buffers, count) };
        objects::forget_command_buffers(buffers);
        if let Some(pool) = state.objects.pools.get(&command_pool) {
            pool.lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .retain(|b| !buffers.contains(b));
        }
    });
    // SAFETY: calling down with the application's arguments.
    unsafe {
        (state.next.fp_v1_0().free_command_buffers)(device, command_pool, count, p_command_buffers)
    };
}

/// `vkCreateDescriptorUpdateTemplate(KHR)`: push-descriptor templates of the compute bind
/// point are kept (pushing with one disturbs compute state revz would bind again).
pub unsafe extern "system" fn create_descriptor_update_template(
    device: vk::Device,
    p_create_info: *const vk::DescriptorUpdateTemplateCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_template: *mut vk::DescriptorUpdateTemplate,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    let Some(next) = state.commands.create_descriptor_update_template else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result = unsafe { next(device, p_create_info, p_allocator, p_template) };
    if result == vk::Result::SUCCESS {
        record(&CREATE_DESCRIPTOR_UPDATE_TEMPLATE, || {
            // SAFETY: valid on success.
            let (info, template) = unsafe { (&*p_create_info, *p_template) };
            let compute_push = info.template_type
                == vk::DescriptorUpdateTemplateType::PUSH_DESCRIPTORS_KHR
                && info.pipeline_bind_point == vk::PipelineBindPoint::COMPUTE;
            // SAFETY: `descriptorUpdateEntryCount` entries.
            let entries = unsafe {
                slice(
                    info.p_descriptor_update_entries,
                    info.descriptor_update_entry_count,
                )
            };
            state
                .copies
                .note_template(template, compute_push.then_some(entries));
            let entries = super::descriptors::TemplateEntries::of(entries);
            if entries.writes_images() {
                state.objects.templates.insert(template, Arc::new(entries));
            }
        });
    }
    result
}

pub unsafe extern "system" fn destroy_descriptor_update_template(
    device: vk::Device,
    template: vk::DescriptorUpdateTemplate,
    p_allocator: *const vk::AllocationCallbacks<'_>,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    record(&DESTROY_DESCRIPTOR_UPDATE_TEMPLATE, || {
        state.copies.forget_template(template);
        state.objects.templates.remove(&template);
    });
    if let Some(next) = state.commands.destroy_descriptor_update_template {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(device, template, p_allocator) }
    }
}

/// `vkCreateCommandPool`: the pool's queue family says whether its command buffers can
/// dispatch (converted copies need compute).
pub unsafe extern "system" fn create_command_pool(
    device: vk::Device,
    p_create_info: *const vk::CommandPoolCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_pool: *mut vk::CommandPool,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result = unsafe {
        (state.next.fp_v1_0().create_command_pool)(device, p_create_info, p_allocator, p_pool)
    };
    if result == vk::Result::SUCCESS {
        record(&CREATE_COMMAND_POOL, || {
            // SAFETY: valid on success.
            let (info, pool) = unsafe { (&*p_create_info, *p_pool) };
            let protected = info.flags.contains(vk::CommandPoolCreateFlags::PROTECTED);
            state
                .copies
                .note_pool(pool, info.queue_family_index, protected);
        });
    }
    result
}

pub unsafe extern "system" fn destroy_command_pool(
    device: vk::Device,
    command_pool: vk::CommandPool,
    p_allocator: *const vk::AllocationCallbacks<'_>,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    record(&DESTROY_COMMAND_POOL, || {
        state.copies.forget_pool(command_pool);
        if let Some(pool) = state.objects.pools.remove(&command_pool) {
            let buffers = pool
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            objects::forget_command_buffers(&buffers);
        }
    });
    // SAFETY: calling down with the application's arguments.
    unsafe { (state.next.fp_v1_0().destroy_command_pool)(device, command_pool, p_allocator) };
}
