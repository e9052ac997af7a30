//! Render pass and framebuffer hooks: what revz records of each (attachment formats, depth
//! clears, depth attachments and depth resolves per subpass, framebuffer views), and the one
//! object revz creates on the application's behalf: a twin render pass whose MIN and MAX depth
//! resolves are swapped.
//!
//! Why a twin: a MIN (MAX) resolve of reversed depth picks the farthest (nearest) sample, so a
//! reversed attachment must be resolved with the other mode. The mode is baked into the render
//! pass, but for passes of one subpass resolve modes do not count for compatibility (Vulkan
//! spec, "Render Pass Compatibility"), so the twin can be begun in place of the application's
//! pass with the application's framebuffers, pipelines and secondaries. Resolves revz cannot
//! swap make their source native instead (`policy::DepthResolve`), decided here at framebuffer
//! creation for ordinary framebuffers.

use std::ffi::c_void;
use std::sync::Arc;

use ash::vk;

use super::{device_state, record};
use crate::boundary::{guarded, EntryPoint};
use crate::chain;
use crate::conv::{flip_resolve_mode, has_depth, has_stencil};
use crate::hooks::resources::slice;
use crate::objects::{RenderPassInfo, SubpassResolve};
use crate::policy::ResolveSupport;
use crate::state::DeviceState;

static CREATE_RENDER_PASS: EntryPoint = EntryPoint::new("vkCreateRenderPass");
static CREATE_RENDER_PASS2: EntryPoint = EntryPoint::new("vkCreateRenderPass2");
static DESTROY_RENDER_PASS: EntryPoint = EntryPoint::new("vkDestroyRenderPass");
static CREATE_FRAMEBUFFER: EntryPoint = EntryPoint::new("vkCreateFramebuffer");
static DESTROY_FRAMEBUFFER: EntryPoint = EntryPoint::new("vkDestroyFramebuffer");

/// Builds a [`RenderPassInfo`] from attachment formats and load ops, and subpass depth
/// attachments and depth resolves (the twin is added by the caller).
fn render_pass_info(
    attachments: impl Iterator<Item = (vk::Format, vk::AttachmentLoadOp)>,
    subpasses: impl Iterator<Item = (Option<u32>, Option<SubpassResolve>)>,
) -> RenderPassInfo {
    let mut info = RenderPassInfo::default();
    for (format, load_op) in attachments {
        info.attachments.push(format);
        info.depth_cleared
            .push(has_depth(format) && load_op == vk::AttachmentLoadOp::CLEAR);
    }
    for (depth, resolve) in subpasses {
        info.subpass_depth
            .push(depth.filter(|&i| i != vk::ATTACHMENT_UNUSED));
        info.subpass_resolve.push(resolve);
    }
    info
}

/// The depth resolve structure in a subpass's pNext chain, if any.
fn depth_resolve_of<'a>(
    subpass: &vk::SubpassDescription2<'a>,
) -> Option<&'a vk::SubpassDescriptionDepthStencilResolve<'a>> {
    // SAFETY: a valid pNext chain (the application's contract).
    unsafe { chain::find(subpass.p_next) }
}

/// A subpass's depth resolve as revz records it: `None` without a depth resolve.
fn subpass_resolve(subpass: &vk::SubpassDescription2<'_>) -> Option<SubpassResolve> {
    let resolve = depth_resolve_of(subpass)?;
    // SAFETY: null or one valid reference.
    let attachment = unsafe { resolve.p_depth_stencil_resolve_attachment.as_ref() }?.attachment;
    (attachment != vk::ATTACHMENT_UNUSED
        && resolve.depth_resolve_mode != vk::ResolveModeFlags::NONE)
        .then_some(SubpassResolve {
            attachment,
            mode: resolve.depth_resolve_mode,
        })
}

/// The depth resolve structure of the twin subpass: the application's with MIN and MAX
/// swapped, chained in front of the rest of the subpass's chain. `Ok(None)`: nothing to swap.
/// `Err`: a MIN/MAX resolve revz cannot swap, and why. `attachments`: the pass's attachments,
/// whose resolve attachment's format says whether the stencil mode counts.
fn swapped_resolve<'a>(
    subpass: &vk::SubpassDescription2<'a>,
    attachments: &[vk::AttachmentDescription2<'_>],
    support: &ResolveSupport,
) -> Result<Option<vk::SubpassDescriptionDepthStencilResolve<'a>>, &'static str> {
    let Some(resolve) = subpass_resolve(subpass) else {
        return Ok(None);
    };
    if flip_resolve_mode(resolve.mode) == resolve.mode {
        return Ok(None);
    }
    let Some(original) = depth_resolve_of(subpass) else {
        return Ok(None);
    };
    // The spec pairs the two modes only for a resolve attachment with a stencil component
    // (VUID-VkSubpassDescriptionDepthStencilResolve-pDepthStencilResolveAttachment-03185,
    // -03186); an index out of range (an invalid pass) counts it, to stay on the safe side.
    let stencil_counts = attachments
        .get(resolve.attachment as usize)
        .is_none_or(|a| has_stencil(a.format));
    let stencil = stencil_counts.then_some(original.stencil_resolve_mode);
    let depth_resolve_mode = support.swapped_depth_mode(resolve.mode, stencil)?;
    // Linking a copy in front of the chain skips the original only when it comes first;
    // elsewhere revz would have to copy structures it does not know.
    if !std::ptr::eq(
        subpass.p_next,
        (original as *const vk::SubpassDescriptionDepthStencilResolve<'_>).cast(),
    ) {
        return Err("another structure precedes it in the subpass's pNext chain");
    }
    // The stencil mode is kept: stencil is never reversed.
    Ok(Some(vk::SubpassDescriptionDepthStencilResolve {
        depth_resolve_mode,
        ..*original
    }))
}

/// Creates the twin of a render pass of one subpass with a MIN/MAX depth resolve; `None` when
/// the pass has none, or it cannot be swapped or created (logged at debug: the attachment then
/// stays native, see `NativeReason::UnswappableResolve`).
fn create_swapped_resolve_twin(
    state: &DeviceState,
    device: vk::Device,
    info: &vk::RenderPassCreateInfo2<'_>,
    next: vk::PFN_vkCreateRenderPass2,
) -> Option<vk::RenderPass> {
    // SAFETY: `subpassCount` subpasses (the application's contract).
    let subpasses = unsafe { slice(info.p_subpasses, info.subpass_count) };
    let swappable = |s: &vk::SubpassDescription2<'_>| {
        subpass_resolve(s).is_some_and(|r| flip_resolve_mode(r.mode) != r.mode)
    };
    if !subpasses.iter().any(swappable) {
        return None;
    }
    let [subpass] = subpasses else {
        log::debug!("a MIN/MAX depth resolve in a render pass of several subpasses: no twin");
        return None;
    };
    // SAFETY: `attachmentCount` attachments (the application's contract).
    let attachments = unsafe { slice(info.p_attachments, info.attachment_count) };
    let resolve = match swapped_resolve(subpass, attachments, &state.resolve_support) {
        Ok(resolve) => resolve?,
        Err(why) => {
            log::debug!("a MIN/MAX depth resolve revz cannot swap: {why}");
            return None;
        }
    };
    let twin_subpass = vk::SubpassDescription2 {
        p_next: (&resolve as *const vk::SubpassDescriptionDepthStencilResolve<'_>).cast::<c_void>(),
        ..*subpass
    };
    let twin_info = vk::RenderPassCreateInfo2 {
        p_subpasses: &twin_subpass,
        ..*info
    };
    let mut twin = vk::RenderPass::null();
    // SAFETY: the application's create info, with one subpass whose resolve structure is ours;
    // revz's own object, so no application allocator.
    let result = unsafe { next(device, &twin_info, std::ptr::null(), &mut twin) };
    if result != vk::Result::SUCCESS {
        log::debug!("the swapped-resolve twin of a render pass failed: {result:?}");
        return None;
    }
    Some(twin)
}

pub unsafe extern "system" fn create_render_pass(
    device: vk::Device,
    p_create_info: *const vk::RenderPassCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_render_pass: *mut vk::RenderPass,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result = unsafe {
        (state.next.fp_v1_0().create_render_pass)(device, p_create_info, p_allocator, p_render_pass)
    };
    if result == vk::Result::SUCCESS {
        record(&CREATE_RENDER_PASS, || {
            // SAFETY: valid on success; arrays sized by their counts.
            let info = unsafe { &*p_create_info };
            // SAFETY: as above.
            let (attachments, subpasses) = unsafe {
                (
                    slice(info.p_attachments, info.attachment_count),
                    slice(info.p_subpasses, info.subpass_count),
                )
            };
            let pass = render_pass_info(
                attachments.iter().map(|a| (a.format, a.load_op)),
                subpasses.iter().map(|s| {
                    // SAFETY: null or one valid reference.
                    let depth = unsafe { s.p_depth_stencil_attachment.as_ref() };
                    (depth.map(|r| r.attachment), None)
                }),
            );
            // SAFETY: valid on success.
            let handle = unsafe { *p_render_pass };
            state.objects.render_passes.insert(handle, Arc::new(pass));
        });
    }
    result
}

pub unsafe extern "system" fn create_render_pass2(
    device: vk::Device,
    p_create_info: *const vk::RenderPassCreateInfo2<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_render_pass: *mut vk::RenderPass,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    let Some(next) = state.commands.create_render_pass2 else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // The twin first, so that output structures in the chain (creation feedback) end up
    // holding what the driver wrote for the application's pass.
    let twin = guarded(
        &CREATE_RENDER_PASS2,
        // SAFETY: a valid create info (the application's contract).
        || create_swapped_resolve_twin(&state, device, unsafe { &*p_create_info }, next),
        || None,
    );
    // SAFETY: calling down with the application's arguments.
    let result = unsafe { next(device, p_create_info, p_allocator, p_render_pass) };
    if result != vk::Result::SUCCESS {
        if let Some(twin) = twin {
            // SAFETY: revz's own object, never used.
            unsafe { (state.next.fp_v1_0().destroy_render_pass)(device, twin, std::ptr::null()) };
        }
    }
    if result == vk::Result::SUCCESS {
        record(&CREATE_RENDER_PASS2, || {
            // SAFETY: valid on success; arrays sized by their counts.
            let info = unsafe { &*p_create_info };
            // SAFETY: as above.
            let (attachments, subpasses) = unsafe {
                (
                    slice(info.p_attachments, info.attachment_count),
                    slice(info.p_subpasses, info.subpass_count),
                )
            };
            let mut pass = render_pass_info(
                attachments.iter().map(|a| (a.format, a.load_op)),
                subpasses.iter().map(|s| {
                    // SAFETY: null or one valid reference.
                    let depth = unsafe { s.p_depth_stencil_attachment.as_ref() };
                    (depth.map(|r| r.attachment), subpass_resolve(s))
                }),
            );
            pass.swapped_resolve_twin = twin;
            // SAFETY: valid on success.
            let handle = unsafe { *p_render_pass };
            state.objects.render_passes.insert(handle, Arc::new(pass));
        });
    }
    result
}

pub unsafe extern "system" fn destroy_render_pass(
    device: vk::Device,
    render_pass: vk::RenderPass,
    p_allocator: *const vk::AllocationCallbacks<'_>,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    let destroy = state.next.fp_v1_0().destroy_render_pass;
    record(&DESTROY_RENDER_PASS, || {
        let removed = state.objects.render_passes.remove(&render_pass);
        let subpasses = removed.as_ref().map_or(0, |pass| pass.subpass_depth.len());
        for subpass in 0..subpasses as u32 {
            let key = crate::objects::SecondaryPass::Subpass(render_pass, subpass);
            state.objects.secondary_targets.remove(&key);
        }
        let twin = removed.and_then(|pass| pass.swapped_resolve_twin);
        if let Some(twin) = twin {
            // SAFETY: revz's own object; command buffers that began it are, like the
            // application's pass, no longer in use (the application's contract for destroying
            // the pass they were recorded with).
            unsafe { destroy(device, twin, std::ptr::null()) };
        }
    });
    // SAFETY: calling down with the application's arguments.
    unsafe { destroy(device, render_pass, p_allocator) };
}

destroy_hook!(
    destroy_framebuffer,
    DESTROY_FRAMEBUFFER,
    vk::Framebuffer,
    framebuffers,
    destroy_framebuffer
);

pub unsafe extern "system" fn create_framebuffer(
    device: vk::Device,
    p_create_info: *const vk::FramebufferCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_framebuffer: *mut vk::Framebuffer,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result = unsafe {
        (state.next.fp_v1_0().create_framebuffer)(device, p_create_info, p_allocator, p_framebuffer)
    };
    if result == vk::Result::SUCCESS {
        record(&CREATE_FRAMEBUFFER, || {
            // SAFETY: valid on success.
            let info = unsafe { &*p_create_info };
            let views: Arc<[vk::ImageView]> =
                if info.flags.contains(vk::FramebufferCreateFlags::IMAGELESS) {
                    Arc::from([])
                } else {
                    // SAFETY: `attachmentCount` views.
                    Arc::from(unsafe { slice(info.p_attachments, info.attachment_count) })
                };
            // Resolves are settled here, before any command buffer records with the views,
            // so that a depth pre-pass recorded before the resolving pass agrees with it.
            if let Some(pass) = state.objects.render_passes.get(&info.render_pass) {
                state.objects.settle_pass_resolves(&pass, &views);
            }
            // SAFETY: valid on success.
            state
                .objects
                .framebuffers
                .insert(unsafe { *p_framebuffer }, views);
        });
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    use vk::ResolveModeFlags as M;

    fn reference(attachment: u32) -> vk::AttachmentReference2<'static> {
        vk::AttachmentReference2 {
            attachment,
            ..Default::default()
        }
    }

    /// A pass's attachments: a multisampled source and a resolve attachment, both of `format`.
    fn attachments(format: vk::Format) -> [vk::AttachmentDescription2<'static>; 2] {
        [vk::AttachmentDescription2::default().format(format); 2]
    }

    /// A device with every depth mode and the given independence.
    fn support(independent_resolve_none: bool, independent_resolve: bool) -> ResolveSupport {
        ResolveSupport {
            depth_modes: M::SAMPLE_ZERO | M::AVERAGE | M::MIN | M::MAX,
            independent_resolve_none,
            independent_resolve,
        }
    }

    #[test]
    fn min_and_max_depth_resolves_are_swapped_in_a_copy_chained_first() {
        static DESTINATION: vk::AttachmentReference2<'static> = vk::AttachmentReference2 {
            s_type: vk::StructureType::ATTACHMENT_REFERENCE_2,
            p_next: std::ptr::null(),
            attachment: 1,
            layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
            aspect_mask: vk::ImageAspectFlags::DEPTH,
            _marker: std::marker::PhantomData,
        };
        let after = vk::BaseInStructure::default();
        let d32 = attachments(vk::Format::D32_SFLOAT);
        for (mode, swapped) in [(M::MIN, M::MAX), (M::MAX, M::MIN)] {
            let resolve = vk::SubpassDescriptionDepthStencilResolve {
                p_next: (&after as *const vk::BaseInStructure).cast(),
                depth_resolve_mode: mode,
                p_depth_stencil_resolve_attachment: &DESTINATION,
                ..Default::default()
            };
            let subpass = vk::SubpassDescription2 {
                p_next: (&resolve as *const vk::SubpassDescriptionDepthStencilResolve<'_>).cast(),
                ..Default::default()
            };
            assert_eq!(
                subpass_resolve(&subpass),
                Some(SubpassResolve {
                    attachment: 1,
                    mode
                })
            );
            let copy = swapped_resolve(&subpass, &d32, &support(false, false))
                .unwrap()
                .unwrap();
            assert_eq!(copy.depth_resolve_mode, swapped);
            assert_eq!(copy.p_next, resolve.p_next, "the rest of the chain follows");
            assert_eq!(
                copy.p_depth_stencil_resolve_attachment,
                resolve.p_depth_stencil_resolve_attachment
            );
        }
    }

    #[test]
    fn linear_resolves_need_no_twin_and_blocked_swaps_say_why() {
        let destination = reference(1);
        let resolve = |depth, stencil| vk::SubpassDescriptionDepthStencilResolve {
            depth_resolve_mode: depth,
            stencil_resolve_mode: stencil,
            p_depth_stencil_resolve_attachment: &destination,
            ..Default::default()
        };
        let subpass_with =
            |r: &vk::SubpassDescriptionDepthStencilResolve<'_>| vk::SubpassDescription2 {
                p_next: (r as *const vk::SubpassDescriptionDepthStencilResolve<'_>).cast(),
                ..Default::default()
            };
        let d32 = attachments(vk::Format::D32_SFLOAT);
        let d32_s8 = attachments(vk::Format::D32_SFLOAT_S8_UINT);
        let dependent = support(false, false);
        for mode in [M::SAMPLE_ZERO, M::AVERAGE] {
            let r = resolve(mode, M::NONE);
            let swapped = swapped_resolve(&subpass_with(&r), &d32_s8, &dependent);
            assert!(swapped.unwrap().is_none());
        }
        let none = resolve(M::NONE, M::NONE);
        assert_eq!(subpass_resolve(&subpass_with(&none)), None);

        // A stencil resolve sharing the mode blocks the swap on a device without
        // independentResolve, where the resolve attachment has stencil.
        let shared = resolve(M::MIN, M::MIN);
        assert!(swapped_resolve(&subpass_with(&shared), &d32_s8, &dependent).is_err());
        // An index out of range counts the stencil mode.
        assert!(swapped_resolve(&subpass_with(&shared), &[], &dependent).is_err());
        // With independentResolve the swapped pair is allowed; the stencil mode is kept.
        let independent = swapped_resolve(&subpass_with(&shared), &d32_s8, &support(true, true));
        let copy = independent.unwrap().unwrap();
        assert_eq!(
            (copy.depth_resolve_mode, copy.stencil_resolve_mode),
            (M::MAX, M::MIN)
        );
        // A resolve attachment without stencil: the stencil mode is ignored.
        let copy = swapped_resolve(&subpass_with(&shared), &d32, &dependent)
            .unwrap()
            .unwrap();
        assert_eq!(
            (copy.depth_resolve_mode, copy.stencil_resolve_mode),
            (M::MAX, M::MIN)
        );
        // The swapped mode must be supported.
        let no_max = ResolveSupport {
            depth_modes: M::SAMPLE_ZERO | M::MIN,
            ..support(true, true)
        };
        let alone = resolve(M::MIN, M::NONE);
        assert!(swapped_resolve(&subpass_with(&alone), &d32, &no_max).is_err());

        // The resolve structure after another one: found, but not swappable in place.
        let min = resolve(M::MIN, M::NONE);
        let before = vk::BaseInStructure {
            s_type: vk::StructureType::FRAGMENT_SHADING_RATE_ATTACHMENT_INFO_KHR,
            p_next: (&min as *const vk::SubpassDescriptionDepthStencilResolve<'_>).cast(),
            ..Default::default()
        };
        let later = vk::SubpassDescription2 {
            p_next: (&before as *const vk::BaseInStructure).cast(),
            ..Default::default()
        };
        assert_eq!(subpass_resolve(&later).map(|r| r.mode), Some(M::MIN));
        assert!(swapped_resolve(&later, &d32, &dependent).is_err());

        let unused = reference(vk::ATTACHMENT_UNUSED);
        let to_unused = vk::SubpassDescriptionDepthStencilResolve {
            depth_resolve_mode: M::MIN,
            p_depth_stencil_resolve_attachment: &unused,
            ..Default::default()
        };
        assert_eq!(subpass_resolve(&subpass_with(&to_unused)), None);
    }
}
