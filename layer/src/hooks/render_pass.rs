//! Render pass and framebuffer hooks: what revz records of each (attachment formats, depth
//! clears, depth attachments and depth resolves per subpass, framebuffer views), and the
//! objects revz creates on the application's behalf: twin render passes whose MIN and MAX
//! depth resolves are swapped, whose UNORM depth attachments are in their float formats
//! (promotion, `crate::policy::DevicePolicy::promoted_format`), or both.
//!
//! Why a promoted twin: a framebuffer's views must have its render pass's attachment formats,
//! and a promoted image's views are in the float format. The twin differs from the
//! application's pass in those formats only; framebuffers of promoted images are created with
//! it (so they are compatible with it, not with the application's pass), passes over them
//! begin as it, and pipelines and secondaries drawn there get the promoted variant made
//! against it (`crate::hooks::pipeline`).
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
use crate::conv::has_stencil;
use crate::hooks::resources::slice;
use crate::objects::{DepthInput, RenderPassInfo, SubpassResolve};
use crate::policy::twins::AttachmentUse;
use crate::policy::{
    clears_depth_at_begin, framebuffer_may_be_promoted, has_promoted_twin, imageless_view_format,
    promoted_twin_format, FramebufferStorage, SubpassResolveFacts, TwinResolve,
};
use crate::state::DeviceState;

static CREATE_RENDER_PASS: EntryPoint = EntryPoint::new("vkCreateRenderPass");
static CREATE_RENDER_PASS2: EntryPoint = EntryPoint::new("vkCreateRenderPass2");
static DESTROY_RENDER_PASS: EntryPoint = EntryPoint::new("vkDestroyRenderPass");
static CREATE_FRAMEBUFFER: EntryPoint = EntryPoint::new("vkCreateFramebuffer");
static DESTROY_FRAMEBUFFER: EntryPoint = EntryPoint::new("vkDestroyFramebuffer");

/// One attachment as [`render_pass_info`] reads it.
struct AttachmentFacts {
    format: vk::Format,
    load_op: vk::AttachmentLoadOp,
    stencil_load_op: vk::AttachmentLoadOp,
    initial: vk::ImageLayout,
    final_layout: vk::ImageLayout,
    /// `VkAttachmentDescriptionStencilLayout` (initial, final), where chained.
    stencil_layouts: Option<(vk::ImageLayout, vk::ImageLayout)>,
}

impl AttachmentFacts {
    fn of(a: &vk::AttachmentDescription) -> Self {
        AttachmentFacts {
            format: a.format,
            load_op: a.load_op,
            stencil_load_op: a.stencil_load_op,
            initial: a.initial_layout,
            final_layout: a.final_layout,
            stencil_layouts: None,
        }
    }

    fn of2(a: &vk::AttachmentDescription2<'_>) -> Self {
        // SAFETY: a valid pNext chain (the application's contract).
        let stencil: Option<&vk::AttachmentDescriptionStencilLayout<'_>> =
            unsafe { chain::find(a.p_next) };
        AttachmentFacts {
            format: a.format,
            load_op: a.load_op,
            stencil_load_op: a.stencil_load_op,
            initial: a.initial_layout,
            final_layout: a.final_layout,
            stencil_layouts: stencil
                .filter(|_| has_stencil(a.format))
                .map(|s| (s.stencil_initial_layout, s.stencil_final_layout)),
        }
    }
}

/// Builds a [`RenderPassInfo`] from its attachments, each subpass's depth attachment and depth
/// resolve, and every attachment reference as (attachment, layout) in subpass order (the twin
/// render passes are added by the caller).
fn render_pass_info(
    attachments: &[AttachmentFacts],
    subpasses: impl Iterator<Item = (Option<u32>, Option<SubpassResolve>)>,
    references: impl Iterator<Item = (u32, vk::ImageLayout)>,
) -> RenderPassInfo {
    let mut info = RenderPassInfo::default();
    let mut uses: Vec<AttachmentUse> = attachments
        .iter()
        .map(|a| AttachmentUse {
            initial: a.initial,
            final_layout: a.final_layout,
            depth_cleared: a.load_op == vk::AttachmentLoadOp::CLEAR,
            stencil_cleared: has_stencil(a.format)
                && a.stencil_load_op == vk::AttachmentLoadOp::CLEAR,
            references: Vec::new(),
            stencil_layouts: a.stencil_layouts,
        })
        .collect();
    for (attachment, layout) in references {
        if let Some(used) = uses.get_mut(attachment as usize) {
            used.references.push(layout);
        }
    }
    for (a, used) in attachments.iter().zip(&uses) {
        info.attachments.push(a.format);
        info.depth_cleared
            .push(clears_depth_at_begin(a.format, a.load_op));
        info.twin_refreshes.push(used.refreshes());
        info.read_after_written_inside
            .push(used.read_after_written_inside());
    }
    for (depth, resolve) in subpasses {
        info.subpass_depth
            .push(depth.filter(|&i| i != vk::ATTACHMENT_UNUSED));
        info.subpass_resolve.push(resolve);
    }
    info
}

/// Records what a render pass's subpasses read as input attachments (each subpass's
/// references, as (attachment, aspect)): the attachments referenced at all
/// (`RenderPassInfo::input_attachments`) and, per subpass, the references that read depth.
fn record_inputs(
    pass: &mut RenderPassInfo,
    subpasses: impl Iterator<Item = Vec<(u32, vk::ImageAspectFlags)>>,
) {
    let subpasses: Vec<Vec<(u32, vk::ImageAspectFlags)>> = subpasses.collect();
    pass.input_attachments = input_attachments(
        pass.attachments.len(),
        subpasses
            .iter()
            .map(|inputs| inputs.iter().map(|&(attachment, _)| attachment).collect()),
    );
    pass.subpass_depth_inputs = depth_inputs(&pass.attachments, subpasses.into_iter());
}

/// Whether each of `count` attachments is referenced by some subpass's input attachments
/// (`subpasses`: each one's referenced attachments, `VK_ATTACHMENT_UNUSED` among them).
fn input_attachments(count: usize, subpasses: impl Iterator<Item = Vec<u32>>) -> Vec<bool> {
    let mut referenced = vec![false; count];
    for attachment in subpasses.flatten() {
        if let Some(slot) = referenced.get_mut(attachment as usize) {
            *slot = true;
        }
    }
    referenced
}

/// Each subpass's input attachments that read depth, from each subpass's input references as
/// (attachment, aspect given for it: empty where none is).
fn depth_inputs(
    formats: &[vk::Format],
    subpasses: impl Iterator<Item = Vec<(u32, vk::ImageAspectFlags)>>,
) -> Vec<Vec<DepthInput>> {
    subpasses
        .map(|inputs| {
            (0u32..)
                .zip(inputs)
                .filter(|&(_, (attachment, aspect))| {
                    crate::policy::reads_depth_input(
                        formats.get(attachment as usize).copied(),
                        aspect,
                    )
                })
                .map(|(index, (attachment, _))| DepthInput { index, attachment })
                .collect()
        })
        .collect()
}

/// The references of a subpass's arrays, in order: input, color, resolve (as many as color,
/// or none where the pointer is null), depth-stencil (none where null).
///
/// # Safety
/// The pointers and counts of a valid subpass description.
unsafe fn subpass_references<'a, R: 'a>(
    (inputs, input_count): (*const R, u32),
    (colors, color_count): (*const R, u32),
    resolves: *const R,
    depth: *const R,
) -> impl Iterator<Item = &'a R> {
    // SAFETY: the caller's contract: arrays sized by their counts, the resolve array by the
    // color count (or null), the depth-stencil reference one element (or null).
    let (inputs, colors, resolves, depth) = unsafe {
        (
            slice(inputs, input_count),
            slice(colors, color_count),
            slice(resolves, color_count),
            depth.as_ref(),
        )
    };
    inputs.iter().chain(colors).chain(resolves).chain(depth)
}

/// Every attachment reference of a `vkCreateRenderPass` subpass, as (attachment, layout).
///
/// # Safety
/// A valid subpass description.
unsafe fn references_of(subpass: &vk::SubpassDescription) -> Vec<(u32, vk::ImageLayout)> {
    // SAFETY: a valid subpass description (the caller's contract).
    unsafe {
        subpass_references(
            (subpass.p_input_attachments, subpass.input_attachment_count),
            (subpass.p_color_attachments, subpass.color_attachment_count),
            subpass.p_resolve_attachments,
            subpass.p_depth_stencil_attachment,
        )
    }
    .filter(|r| r.attachment != vk::ATTACHMENT_UNUSED)
    .map(|r| (r.attachment, r.layout))
    .collect()
}

/// Every attachment reference of a `vkCreateRenderPass2` subpass, as (attachment, layout):
/// the separate stencil layout of a depth-stencil or input reference counts as a use too,
/// and so does the depth resolve attachment.
///
/// # Safety
/// A valid subpass description.
unsafe fn references_of2(subpass: &vk::SubpassDescription2<'_>) -> Vec<(u32, vk::ImageLayout)> {
    // SAFETY: a valid subpass description (the caller's contract).
    let references = unsafe {
        subpass_references(
            (subpass.p_input_attachments, subpass.input_attachment_count),
            (subpass.p_color_attachments, subpass.color_attachment_count),
            subpass.p_resolve_attachments,
            subpass.p_depth_stencil_attachment,
        )
    };
    // SAFETY: null or one valid reference.
    let depth_resolve = depth_resolve_of(subpass)
        .and_then(|r| unsafe { r.p_depth_stencil_resolve_attachment.as_ref() });
    let mut out = Vec::new();
    for r in references.chain(depth_resolve) {
        if r.attachment == vk::ATTACHMENT_UNUSED {
            continue;
        }
        out.push((r.attachment, r.layout));
        // SAFETY: a valid pNext chain (the application's contract).
        let stencil: Option<&vk::AttachmentReferenceStencilLayout<'_>> =
            unsafe { chain::find(r.p_next) };
        if let Some(stencil) = stencil {
            out.push((r.attachment, stencil.stencil_layout));
        }
    }
    out
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

/// What the policy needs to know of a subpass's depth resolve
/// ([`crate::policy::ResolveSupport::twin_resolve`]): `None` without one. `attachments`: the
/// pass's attachments, whose resolve attachment's format says whether the stencil mode counts.
fn resolve_facts(
    subpass: &vk::SubpassDescription2<'_>,
    attachments: &[vk::AttachmentDescription2<'_>],
) -> Option<SubpassResolveFacts> {
    let resolve = subpass_resolve(subpass)?;
    let original = depth_resolve_of(subpass)?;
    // The spec pairs the two modes only for a resolve attachment with a stencil component
    // (VUID-VkSubpassDescriptionDepthStencilResolve-pDepthStencilResolveAttachment-03185,
    // -03186); an index out of range (an invalid pass) counts it, to stay on the safe side.
    let stencil_counts = attachments
        .get(resolve.attachment as usize)
        .is_none_or(|a| has_stencil(a.format));
    Some(SubpassResolveFacts {
        mode: resolve.mode,
        stencil: stencil_counts.then_some(original.stencil_resolve_mode),
        chained_first: std::ptr::eq(
            subpass.p_next,
            (original as *const vk::SubpassDescriptionDepthStencilResolve<'_>).cast(),
        ),
    })
}

/// The depth resolve structure of the twin subpass: the application's with the depth mode
/// the policy chose, chained in front of the rest of the subpass's chain (the policy swaps
/// only a structure that comes first). The stencil mode is kept: stencil is never reversed.
fn swapped_resolve<'a>(
    subpass: &vk::SubpassDescription2<'a>,
    depth_resolve_mode: vk::ResolveModeFlags,
) -> Option<vk::SubpassDescriptionDepthStencilResolve<'a>> {
    let original = depth_resolve_of(subpass)?;
    Some(vk::SubpassDescriptionDepthStencilResolve {
        depth_resolve_mode,
        ..*original
    })
}

/// Creates the twin of a render pass of one subpass with a MIN/MAX depth resolve, where the
/// policy gives it one ([`crate::policy::ResolveSupport::twin_resolve`]); `None` when the pass
/// has none, or it cannot be swapped or created (logged at debug: the attachment then stays
/// native, see `NativeReason::UnswappableResolve`).
fn create_swapped_resolve_twin(
    state: &DeviceState,
    device: vk::Device,
    info: &vk::RenderPassCreateInfo2<'_>,
    next: vk::PFN_vkCreateRenderPass2,
) -> Option<vk::RenderPass> {
    // SAFETY: `subpassCount` subpasses (the application's contract).
    let subpasses = unsafe { slice(info.p_subpasses, info.subpass_count) };
    // SAFETY: `attachmentCount` attachments (the application's contract).
    let attachments = unsafe { slice(info.p_attachments, info.attachment_count) };
    let facts = subpasses.iter().map(|s| resolve_facts(s, attachments));
    let mode = match state.resolve_support.twin_resolve(facts) {
        TwinResolve::Unneeded => return None,
        TwinResolve::SeveralSubpasses => {
            log::debug!("a MIN/MAX depth resolve in a render pass of several subpasses: no twin");
            return None;
        }
        TwinResolve::Unswappable(why) => {
            log::debug!("a MIN/MAX depth resolve revz cannot swap: {why}");
            return None;
        }
        TwinResolve::Swapped(mode) => mode,
    };
    let [subpass] = subpasses else {
        return None;
    };
    let resolve = swapped_resolve(subpass, mode)?;
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

/// The attachments of a render pass's promoted twin, where the policy gives it one
/// ([`has_promoted_twin`]): the application's (`attachments`, read only where promotion is
/// on) with each UNORM depth format replaced by its float one ([`promoted_twin_format`]).
fn promoted_attachments<'a, T: Copy + 'a>(
    promote: bool,
    attachments: impl FnOnce() -> &'a [T],
    format: impl Fn(&mut T) -> &mut vk::Format,
) -> Option<Vec<T>> {
    let mut copy = Vec::new();
    has_promoted_twin(promote, || {
        copy = attachments().to_vec();
        let mut changed = false;
        for attachment in &mut copy {
            let format = format(attachment);
            if let Some(float) = promoted_twin_format(*format) {
                *format = float;
                changed = true;
            }
        }
        changed
    })
    .then_some(copy)
}

/// Logs a twin render pass that could not be created (its framebuffers then keep the
/// application's pass: see [`create_framebuffer`]).
fn twin_failed(kind: &str, result: vk::Result) {
    log::warn!("the {kind} twin of a render pass could not be created ({result:?})");
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
    let create = state.next.fp_v1_0().create_render_pass;
    let promoted_twin = guarded(
        &CREATE_RENDER_PASS,
        || {
            // SAFETY: a valid create info (the application's contract).
            let info = unsafe { &*p_create_info };
            let promoted = promoted_attachments(
                state.policy.promote,
                // SAFETY: `attachmentCount` attachments.
                || unsafe { slice(info.p_attachments, info.attachment_count) },
                |a| &mut a.format,
            )?;
            let twin_info = vk::RenderPassCreateInfo {
                p_attachments: promoted.as_ptr(),
                ..*info
            };
            let mut twin = vk::RenderPass::null();
            // SAFETY: the application's create info with float depth formats; revz's own
            // object.
            let result = unsafe { create(device, &twin_info, std::ptr::null(), &mut twin) };
            if result != vk::Result::SUCCESS {
                twin_failed("promoted", result);
                return None;
            }
            Some(twin)
        },
        || None,
    );
    // SAFETY: calling down with the application's arguments.
    let result = unsafe { create(device, p_create_info, p_allocator, p_render_pass) };
    if result != vk::Result::SUCCESS {
        if let Some(twin) = promoted_twin {
            // SAFETY: revz's own object, never used.
            unsafe { (state.next.fp_v1_0().destroy_render_pass)(device, twin, std::ptr::null()) };
        }
    }
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
            let facts: Vec<AttachmentFacts> = attachments.iter().map(AttachmentFacts::of).collect();
            let mut pass = render_pass_info(
                &facts,
                subpasses.iter().map(|s| {
                    // SAFETY: null or one valid reference.
                    let depth = unsafe { s.p_depth_stencil_attachment.as_ref() };
                    (depth.map(|r| r.attachment), None)
                }),
                // SAFETY: valid subpass descriptions (the application's contract).
                subpasses.iter().flat_map(|s| unsafe { references_of(s) }),
            );
            // SAFETY: a valid pNext chain (the application's contract).
            let aspects = unsafe {
                chain::find::<vk::RenderPassInputAttachmentAspectCreateInfo<'_>>(info.p_next)
            }
            // SAFETY: `aspectReferenceCount` references.
            .map_or(&[][..], |a| unsafe {
                slice(a.p_aspect_references, a.aspect_reference_count)
            });
            record_inputs(
                &mut pass,
                (0u32..).zip(subpasses).map(|(n, s)| {
                    // SAFETY: `inputAttachmentCount` references.
                    let inputs = unsafe { slice(s.p_input_attachments, s.input_attachment_count) };
                    (0u32..)
                        .zip(inputs)
                        .map(|(index, r)| {
                            let aspect = aspects
                                .iter()
                                .find(|a| a.subpass == n && a.input_attachment_index == index)
                                .map_or(vk::ImageAspectFlags::empty(), |a| a.aspect_mask);
                            (r.attachment, aspect)
                        })
                        .collect()
                }),
            );
            pass.promoted_twin = promoted_twin;
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
    let twins = guarded(
        &CREATE_RENDER_PASS2,
        || {
            // SAFETY: a valid create info (the application's contract).
            let info = unsafe { &*p_create_info };
            let swapped = create_swapped_resolve_twin(&state, device, info, next);
            // SAFETY: `attachmentCount` attachments.
            let attachments = unsafe { slice(info.p_attachments, info.attachment_count) };
            let promoted =
                promoted_attachments(state.policy.promote, || attachments, |a| &mut a.format);
            let (promoted_twin, promoted_swapped) = match promoted {
                Some(promoted) => {
                    let promoted_info = vk::RenderPassCreateInfo2 {
                        p_attachments: promoted.as_ptr(),
                        ..*info
                    };
                    let mut twin = vk::RenderPass::null();
                    // SAFETY: the application's create info with float depth formats.
                    let result =
                        unsafe { next(device, &promoted_info, std::ptr::null(), &mut twin) };
                    let twin = if result == vk::Result::SUCCESS {
                        Some(twin)
                    } else {
                        twin_failed("promoted", result);
                        None
                    };
                    let swapped = swapped.and(twin).and_then(|_| {
                        create_swapped_resolve_twin(&state, device, &promoted_info, next)
                    });
                    (twin, swapped)
                }
                None => (None, None),
            };
            [swapped, promoted_twin, promoted_swapped]
        },
        || [None; 3],
    );
    // SAFETY: calling down with the application's arguments.
    let result = unsafe { next(device, p_create_info, p_allocator, p_render_pass) };
    if result != vk::Result::SUCCESS {
        for twin in twins.into_iter().flatten() {
            // SAFETY: revz's own object, never used.
            unsafe { (state.next.fp_v1_0().destroy_render_pass)(device, twin, std::ptr::null()) };
        }
    }
    let [twin, promoted_twin, promoted_swapped_twin] = twins;
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
            let facts: Vec<AttachmentFacts> =
                attachments.iter().map(AttachmentFacts::of2).collect();
            let mut pass = render_pass_info(
                &facts,
                subpasses.iter().map(|s| {
                    // SAFETY: null or one valid reference.
                    let depth = unsafe { s.p_depth_stencil_attachment.as_ref() };
                    (depth.map(|r| r.attachment), subpass_resolve(s))
                }),
                // SAFETY: valid subpass descriptions (the application's contract).
                subpasses.iter().flat_map(|s| unsafe { references_of2(s) }),
            );
            record_inputs(
                &mut pass,
                subpasses.iter().map(|s| {
                    // SAFETY: `inputAttachmentCount` references.
                    unsafe { slice(s.p_input_attachments, s.input_attachment_count) }
                        .iter()
                        .map(|r| (r.attachment, r.aspect_mask))
                        .collect()
                }),
            );
            pass.swapped_resolve_twin = twin;
            pass.promoted_twin = promoted_twin;
            pass.promoted_swapped_twin = promoted_swapped_twin;
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
            state.objects.secondary_promoted.remove(&key);
        }
        for twin in removed.iter().flat_map(|pass| pass.twins()) {
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
    framebuffers | promoted_framebuffers,
    destroy_framebuffer
);

/// Whether an imageless framebuffer's attachment would be a promoted image: the policy's
/// decision on what its attachment info says (usage, flags, size, layers; optimal tiling, as
/// for any attachment, and one sample, which the info does not give).
fn imageless_promoted(
    state: &DeviceState,
    format: vk::Format,
    attachment: &vk::FramebufferAttachmentImageInfo<'_>,
) -> bool {
    let facts = crate::policy::ImageFacts::imageless_attachment(attachment.usage, attachment.flags);
    let image = vk::ImageCreateInfo {
        flags: attachment.flags,
        image_type: vk::ImageType::TYPE_2D,
        format,
        extent: vk::Extent3D {
            width: attachment.width,
            height: attachment.height,
            depth: 1,
        },
        mip_levels: 1,
        array_layers: attachment.layer_count,
        samples: vk::SampleCountFlags::TYPE_1,
        tiling: vk::ImageTiling::OPTIMAL,
        usage: attachment.usage,
        ..Default::default()
    };
    matches!(
        state.policy.promoted_format(format, facts, |float| state
            .image_formats
            .supports(&image, float)),
        Ok(Some(_))
    )
}

/// What a framebuffer is created with in place of the application's create info: the
/// promoted twin of its pass, and for an imageless one, attachment infos naming the float
/// formats (the arrays they point into live here).
struct FramebufferCreation<'a> {
    info: vk::FramebufferCreateInfo<'a>,
    _images: Vec<vk::FramebufferAttachmentImageInfo<'a>>,
    _formats: Vec<Vec<vk::Format>>,
    _chain: Option<chain::Spliced>,
}

/// Plans a framebuffer's creation; `None`: the application's create info as it is.
///
/// # Safety
/// `info` is the application's valid create info.
unsafe fn plan_framebuffer<'a>(
    state: &DeviceState,
    info: &vk::FramebufferCreateInfo<'a>,
    pass: &RenderPassInfo,
) -> Option<FramebufferCreation<'a>> {
    if !framebuffer_may_be_promoted(
        state.policy.promote,
        (0..pass.attachments.len()).map(|i| pass.promotable(i)),
    ) {
        return None;
    }
    let imageless = info.flags.contains(vk::FramebufferCreateFlags::IMAGELESS);
    // SAFETY: a valid chain.
    let images_info =
        unsafe { chain::find::<vk::FramebufferAttachmentsCreateInfo<'_>>(info.p_next) }
            .filter(|_| imageless);
    // SAFETY: `attachmentImageInfoCount` infos.
    let images = images_info.map_or(&[][..], |images| unsafe {
        slice(
            images.p_attachment_image_infos,
            images.attachment_image_info_count,
        )
    });
    // SAFETY: `attachmentCount` views.
    let views = unsafe { slice(info.p_attachments, info.attachment_count) };
    let promoted = |index: usize| {
        if imageless {
            images
                .get(index)
                .is_some_and(|image| imageless_promoted(state, pass.attachments[index], image))
        } else {
            views
                .get(index)
                .is_some_and(|&view| state.objects.view_promoted(view).is_some())
        }
    };
    let storage = FramebufferStorage::of(
        (0..pass.attachments.len())
            .filter(|&i| pass.promotable(i))
            .map(promoted),
    );
    match storage {
        FramebufferStorage::Unpromoted => return None,
        FramebufferStorage::Mixed => {
            log::error!(
                "a framebuffer of render pass {:?} mixes promoted (float) and UNORM depth images \
                 (one of them is copied, linear, external or unsupported as float): no render \
                 pass fits both; it is created as the application asked, and the driver may \
                 reject it. Set promote_depth_formats = never for this application.",
                info.render_pass
            );
            return None;
        }
        FramebufferStorage::Promoted => {}
    }
    let Some(twin) = pass.promoted_twin else {
        log::error!(
            "the promoted twin of render pass {:?} is missing: a framebuffer of promoted depth \
             images is created with the application's pass, and the driver may reject it",
            info.render_pass
        );
        return None;
    };
    let mut creation = FramebufferCreation {
        info: vk::FramebufferCreateInfo {
            render_pass: twin,
            ..*info
        },
        _images: Vec::new(),
        _formats: Vec::new(),
        _chain: None,
    };
    if let Some(images_info) = images_info {
        creation._formats = images
            .iter()
            .enumerate()
            .map(|(index, image)| {
                // SAFETY: `viewFormatCount` formats.
                let formats = unsafe { slice(image.p_view_formats, image.view_format_count) };
                let original = pass.attachments.get(index).copied();
                formats
                    .iter()
                    .map(|&f| imageless_view_format(f, original, pass.promotable(index)))
                    .collect()
            })
            .collect();
        creation._images = images
            .iter()
            .zip(&creation._formats)
            .map(|(image, formats)| vk::FramebufferAttachmentImageInfo {
                p_view_formats: formats.as_ptr(),
                ..*image
            })
            .collect();
        let replacement = vk::FramebufferAttachmentsCreateInfo {
            attachment_image_info_count: creation._images.len() as u32,
            p_attachment_image_infos: creation._images.as_ptr(),
            ..*images_info
        };
        // SAFETY: a valid chain; the copies live in `creation` (vectors whose buffers do not
        // move with it).
        let Some(spliced) = (unsafe { chain::splice(info.p_next, Some(&replacement)) }) else {
            log::error!(
                "an imageless framebuffer's attachment infos follow a structure revz cannot \
                 copy: it is created as the application asked, and the driver may reject it"
            );
            return None;
        };
        creation.info.p_next = spliced.head();
        creation._chain = Some(spliced);
    }
    Some(creation)
}

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
    let creation = guarded(
        &CREATE_FRAMEBUFFER,
        || {
            // SAFETY: a valid create info (the application's contract).
            let info = unsafe { &*p_create_info };
            let pass = state.objects.render_passes.get(&info.render_pass)?;
            // SAFETY: as above.
            unsafe { plan_framebuffer(&state, info, &pass) }
        },
        || None,
    );
    let info_down = creation
        .as_ref()
        .map_or(p_create_info, |creation| &creation.info as *const _);
    // SAFETY: calling down with the application's arguments, or its create info with the
    // promoted twin of its render pass (and float formats in imageless attachment infos).
    let result = unsafe {
        (state.next.fp_v1_0().create_framebuffer)(device, info_down, p_allocator, p_framebuffer)
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
            let framebuffer = unsafe { *p_framebuffer };
            if creation.is_some() {
                state.objects.promoted_framebuffers.insert(framebuffer, ());
            }
            state.objects.framebuffers.insert(framebuffer, views);
        });
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::policy::ResolveSupport;

    /// Attachments referenced as input attachments by any subpass, whatever aspect is read:
    /// unused references and indices past the attachments count for nothing.
    #[test]
    fn input_attachments_are_those_any_subpass_references() {
        let subpasses = [vec![], vec![2, vk::ATTACHMENT_UNUSED], vec![0, 2, 7]];
        assert_eq!(
            input_attachments(4, subpasses.into_iter()),
            [true, false, true, false]
        );
        assert_eq!(input_attachments(2, std::iter::empty()), [false, false]);
    }

    /// A `vkCreateRenderPass2` attachment's separate stencil layouts are read (for a format
    /// with stencil), and make its twin's aspects refresh apart.
    #[test]
    fn separate_stencil_layouts_of_an_attachment_are_read() {
        use vk::ImageLayout as L;
        let mut stencil = vk::AttachmentDescriptionStencilLayout::default()
            .stencil_initial_layout(L::UNDEFINED)
            .stencil_final_layout(L::STENCIL_ATTACHMENT_OPTIMAL);
        let attachment = vk::AttachmentDescription2::default()
            .format(vk::Format::D32_SFLOAT_S8_UINT)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .stencil_load_op(vk::AttachmentLoadOp::CLEAR)
            .initial_layout(L::UNDEFINED)
            .final_layout(L::DEPTH_READ_ONLY_OPTIMAL)
            .push_next(&mut stencil);
        let facts = AttachmentFacts::of2(&attachment);
        assert_eq!(
            facts.stencil_layouts,
            Some((L::UNDEFINED, L::STENCIL_ATTACHMENT_OPTIMAL))
        );
        let info = render_pass_info(
            &[facts],
            [(Some(0), None)].into_iter(),
            [(0, L::DEPTH_ATTACHMENT_OPTIMAL)].into_iter(),
        );
        assert_eq!(
            info.twin_refreshes[0].at(crate::policy::twins::PassMoment::End),
            [
                Some((vk::ImageAspectFlags::DEPTH, L::DEPTH_READ_ONLY_OPTIMAL)),
                None
            ]
        );
        // A depth-only format ignores them.
        let depth_only = vk::AttachmentDescription2 {
            format: vk::Format::D32_SFLOAT,
            ..attachment
        };
        assert_eq!(AttachmentFacts::of2(&depth_only).stencil_layouts, None);
    }

    /// Every reference of a subpass counts, in order, unused ones left out; a
    /// `vkCreateRenderPass2` subpass's separate stencil layout and depth resolve attachment too
    /// (what decides where a read twin is refreshed: `policy::twins`).
    #[test]
    fn subpass_references_name_every_attachment_use_with_its_layout() {
        use vk::ImageLayout as L;
        let reference = |attachment, layout| vk::AttachmentReference { attachment, layout };
        let inputs = [reference(3, L::SHADER_READ_ONLY_OPTIMAL)];
        let colors = [
            reference(0, L::COLOR_ATTACHMENT_OPTIMAL),
            reference(vk::ATTACHMENT_UNUSED, L::UNDEFINED),
        ];
        let resolves = [
            reference(1, L::COLOR_ATTACHMENT_OPTIMAL),
            reference(vk::ATTACHMENT_UNUSED, L::UNDEFINED),
        ];
        let depth = reference(2, L::DEPTH_STENCIL_READ_ONLY_OPTIMAL);
        let subpass = vk::SubpassDescription::default()
            .input_attachments(&inputs)
            .color_attachments(&colors)
            .resolve_attachments(&resolves)
            .depth_stencil_attachment(&depth);
        // SAFETY: a valid subpass description of live locals.
        let found = unsafe { references_of(&subpass) };
        assert_eq!(
            found,
            [
                (3, L::SHADER_READ_ONLY_OPTIMAL),
                (0, L::COLOR_ATTACHMENT_OPTIMAL),
                (1, L::COLOR_ATTACHMENT_OPTIMAL),
                (2, L::DEPTH_STENCIL_READ_ONLY_OPTIMAL),
            ]
        );

        let mut stencil_layout = vk::AttachmentReferenceStencilLayout::default()
            .stencil_layout(L::STENCIL_ATTACHMENT_OPTIMAL);
        let depth2 = vk::AttachmentReference2::default()
            .attachment(0)
            .layout(L::DEPTH_READ_ONLY_OPTIMAL)
            .push_next(&mut stencil_layout);
        let resolved = vk::AttachmentReference2::default()
            .attachment(1)
            .layout(L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL);
        let mut resolve = vk::SubpassDescriptionDepthStencilResolve::default()
            .depth_resolve_mode(vk::ResolveModeFlags::SAMPLE_ZERO)
            .depth_stencil_resolve_attachment(&resolved);
        let subpass2 = vk::SubpassDescription2::default()
            .depth_stencil_attachment(&depth2)
            .push_next(&mut resolve);
        // SAFETY: as above.
        let found = unsafe { references_of2(&subpass2) };
        assert_eq!(
            found,
            [
                (0, L::DEPTH_READ_ONLY_OPTIMAL),
                (0, L::STENCIL_ATTACHMENT_OPTIMAL),
                (1, L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL),
            ]
        );
    }

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

    /// The twin subpass's resolve structure, as the hook gathers the facts of a pass of one
    /// subpass, asks the policy and applies its answer: `Ok(None)`, nothing to swap; `Err`,
    /// why it cannot be swapped.
    fn twin<'a>(
        subpass: &vk::SubpassDescription2<'a>,
        attachments: &[vk::AttachmentDescription2<'_>],
        support: &ResolveSupport,
    ) -> Result<Option<vk::SubpassDescriptionDepthStencilResolve<'a>>, &'static str> {
        match support.twin_resolve([resolve_facts(subpass, attachments)]) {
            TwinResolve::Unneeded => Ok(None),
            TwinResolve::SeveralSubpasses => unreachable!("one subpass"),
            TwinResolve::Unswappable(why) => Err(why),
            TwinResolve::Swapped(mode) => Ok(swapped_resolve(subpass, mode)),
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
            let copy = twin(&subpass, &d32, &support(false, false))
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
            let swapped = twin(&subpass_with(&r), &d32_s8, &dependent);
            assert!(swapped.unwrap().is_none());
        }
        let none = resolve(M::NONE, M::NONE);
        assert_eq!(subpass_resolve(&subpass_with(&none)), None);

        // A stencil resolve sharing the mode blocks the swap on a device without
        // independentResolve, where the resolve attachment has stencil.
        let shared = resolve(M::MIN, M::MIN);
        assert!(twin(&subpass_with(&shared), &d32_s8, &dependent).is_err());
        // An index out of range counts the stencil mode.
        assert!(twin(&subpass_with(&shared), &[], &dependent).is_err());
        // With independentResolve the swapped pair is allowed; the stencil mode is kept.
        let independent = twin(&subpass_with(&shared), &d32_s8, &support(true, true));
        let copy = independent.unwrap().unwrap();
        assert_eq!(
            (copy.depth_resolve_mode, copy.stencil_resolve_mode),
            (M::MAX, M::MIN)
        );
        // A resolve attachment without stencil: the stencil mode is ignored.
        let copy = twin(&subpass_with(&shared), &d32, &dependent)
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
        assert!(twin(&subpass_with(&alone), &d32, &no_max).is_err());

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
        assert!(twin(&later, &d32, &dependent).is_err());

        let unused = reference(vk::ATTACHMENT_UNUSED);
        let to_unused = vk::SubpassDescriptionDepthStencilResolve {
            depth_resolve_mode: M::MIN,
            p_depth_stencil_resolve_attachment: &unused,
            ..Default::default()
        };
        assert_eq!(subpass_resolve(&subpass_with(&to_unused)), None);
    }
}
