//! Command buffer begins (what a secondary inherits: its depth target, promotion, viewports)
//! and `vkCmdExecuteCommands`.

#![allow(clippy::wildcard_imports)]

use super::*;
use crate::policy::{first_promoted_format, pass_promotable, promoted_attachment_format};

/// A secondary's begin info as it goes down when it continues a promoted pass: its
/// inheritance names the promoted twin, or the float rendering formats (the copies it points
/// into live here).
struct PromotedInheritance<'a> {
    begin: vk::CommandBufferBeginInfo<'a>,
    _inheritance: Box<vk::CommandBufferInheritanceInfo<'a>>,
    _chain: Option<chain::Spliced>,
}

/// The begin info of a secondary continuing a promoted pass (`None`: the application's is
/// right as it is, or cannot be changed: logged).
fn promoted_inheritance<'a>(
    device: &DeviceState,
    begin: &vk::CommandBufferBeginInfo<'a>,
    inheritance: &vk::CommandBufferInheritanceInfo<'a>,
) -> Option<PromotedInheritance<'a>> {
    let mut copy = *inheritance;
    let mut spliced = None;
    if inheritance.render_pass != vk::RenderPass::null() {
        let pass = device.objects.render_passes.get(&inheritance.render_pass)?;
        copy.render_pass = pass.promoted_twin?;
    } else {
        // SAFETY: a valid pNext chain (the application's contract).
        let rendering = unsafe {
            chain::find::<vk::CommandBufferInheritanceRenderingInfo<'_>>(inheritance.p_next)
        }?;
        let replacement = vk::CommandBufferInheritanceRenderingInfo {
            depth_attachment_format: promoted_attachment_format(rendering.depth_attachment_format),
            stencil_attachment_format: promoted_attachment_format(
                rendering.stencil_attachment_format,
            ),
            ..*rendering
        };
        // SAFETY: as above; the copies live in the result.
        let Some(chain) = (unsafe { chain::splice(inheritance.p_next, Some(&replacement)) }) else {
            log::error!(
                "a secondary continuing rendering into a promoted depth image has a structure \
                 revz cannot copy before its inheritance rendering info: it keeps the UNORM \
                 format, and the driver may reject it"
            );
            return None;
        };
        copy.p_next = chain.head();
        spliced = Some(chain);
    }
    let inheritance = Box::new(copy);
    Some(PromotedInheritance {
        begin: vk::CommandBufferBeginInfo {
            p_inheritance_info: &*inheritance,
            ..*begin
        },
        _inheritance: inheritance,
        _chain: spliced,
    })
}

pub unsafe extern "system" fn begin_command_buffer(
    buffer: vk::CommandBuffer,
    p_begin: *const vk::CommandBufferBeginInfo<'_>,
) -> vk::Result {
    static ENTRY: EntryPoint = EntryPoint::new("vkBeginCommandBuffer");
    let mut promoted_begin = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid begin info (the application's contract).
        let begin = unsafe { &*p_begin };
        // The inheritance info is ignored (and may be garbage) for primaries.
        let continues = entry.secondary
            && begin
                .flags
                .contains(vk::CommandBufferUsageFlags::RENDER_PASS_CONTINUE);
        // SAFETY: null or valid; only read for secondaries continuing a render pass.
        let inheritance = unsafe { begin.p_inheritance_info.as_ref() }.filter(|_| continues);
        let target = inheritance.map_or(Target::None, |i| inherited_target(entry, i));
        let reversed_inputs = inheritance.is_some_and(|i| inherited_reversed_inputs(entry, i));
        let promoted = inheritance.and_then(|i| inherited_promotion(entry, i));
        if let (Some(_), Some(inheritance)) = (promoted, inheritance) {
            promoted_begin = promoted_inheritance(&entry.device, begin, inheritance);
        }
        *entry.scope() = PassScope::default();
        {
            let mut copies = entry.copies();
            copies.begin(&entry.device);
            // A secondary may run inside the primary's conditional rendering.
            // SAFETY: a valid begin info (the application's contract).
            copies.conditional =
                entry.secondary && unsafe { inherits_conditional_rendering(begin) };
        }
        let mut state = entry.state();
        // Cameras matter to the precise path only (no lock in flip mode).
        let cameras = match entry.device.policy.rewrite() {
            Some(_) => entry.device.cameras.learned(),
            None => revz_math::Cameras::default(),
        };
        state.begin(target, entry.device.reversing().reversal, cameras);
        if entry.device.policy.rewrite().is_some() {
            // Recordings of one frame pin one range for a camera new to the device.
            state.share_first_seen(entry.device.cameras.first_seen());
        }
        // Infinite mode: a secondary continuing a pass into an image whose camera revz
        // remembers starts from it (its flip-path state and clears), as the pass did.
        if let Some(image) = inheritance
            .filter(|_| entry.device.remembers_cameras())
            .and_then(|i| inherited_depth_image(entry, i))
        {
            super::passes::enter_cameras(&entry.device, &mut state, &[image]);
        }
        if continues {
            // Inside the pass it continues, with or without a depth attachment.
            state.set_target(target);
            state.set_reversed_inputs(reversed_inputs);
            // Infinite mode: its depth image stores complementary depth (from an inherited
            // framebuffer, else from what its render pass reads).
            let complementary = inheritance
                .filter(|_| entry.device.remembers_cameras())
                .is_some_and(|i| inherited_complementary(entry, i));
            state.set_complementary_target(complementary);
        }
        state.set_promoted(promoted);
        if entry.secondary && inherits_viewports(begin) {
            state.inherit_viewports();
        }
    });
    let p_begin = promoted_begin
        .as_ref()
        .map_or(p_begin, |promoted| &promoted.begin as *const _);
    match device {
        // SAFETY: calling down with the application's arguments (a promoted pass's
        // inheritance naming its twin or its float formats).
        Some(device) => unsafe { (device.next.fp_v1_0().begin_command_buffer)(buffer, p_begin) },
        None => vk::Result::ERROR_INITIALIZATION_FAILED,
    }
}

/// Whether a secondary continues a promoted pass, and the UNORM format of its depth
/// attachment (`crate::policy::inherited_promoted`, from its inherited framebuffer, the pass
/// and the format's images).
pub(super) fn inherited_promotion(
    entry: &CommandBufferEntry,
    inheritance: &vk::CommandBufferInheritanceInfo<'_>,
) -> Option<vk::Format> {
    let device = &entry.device;
    if !device.policy.promote {
        return None;
    }
    let (framebuffer, key, format) = if inheritance.render_pass != vk::RenderPass::null() {
        let pass = device.objects.render_passes.get(&inheritance.render_pass)?;
        if !pass_promotable((0..pass.attachments.len()).map(|i| pass.promotable(i))) {
            return None;
        }
        let framebuffer = inheritance.framebuffer;
        // Any tracked framebuffer (imageless ones too) says how it was created.
        let created_promoted = device.objects.framebuffers.get(&framebuffer).map(|_| {
            device
                .objects
                .promoted_framebuffers
                .get(&framebuffer)
                .is_some()
        });
        (
            created_promoted,
            SecondaryPass::Subpass(inheritance.render_pass, inheritance.subpass),
            subpass_depth_format(&pass, inheritance.subpass),
        )
    } else {
        // SAFETY: a valid pNext chain (the application's contract).
        let rendering = unsafe {
            chain::find::<vk::CommandBufferInheritanceRenderingInfo<'_>>(inheritance.p_next)
        }?;
        let format = first_promoted_format(
            rendering.depth_attachment_format,
            rendering.stencil_attachment_format,
        )?;
        (None, SecondaryPass::Rendering(format), Some(format))
    };
    let (promoted, guessed) = crate::policy::inherited_promoted(
        framebuffer,
        format,
        || device.objects.secondary_promoted.get(&key),
        |format| device.objects.count_promoted(format),
    );
    if guessed {
        static MIXED: OnceLock<()> = OnceLock::new();
        MIXED.get_or_init(|| {
            log::warn!(
                "a secondary command buffer without a framebuffer draws into {:?}, which \
                 has both promoted and unpromoted images, in a pass not yet begun for \
                 secondaries: assuming promoted",
                format.unwrap_or_default()
            )
        });
    }
    promoted
}

/// The format of a subpass's depth attachment, if it has one.
fn subpass_depth_format(pass: &crate::objects::RenderPassInfo, subpass: u32) -> Option<vk::Format> {
    let index = pass
        .subpass_depth
        .get(subpass as usize)
        .copied()
        .flatten()?;
    pass.attachments.get(index as usize).copied()
}

/// Whether a secondary inherits its viewports from the primary that executes it
/// (`VK_NV_inherited_viewport_scissor`).
pub(super) fn inherits_viewports(begin: &vk::CommandBufferBeginInfo<'_>) -> bool {
    // SAFETY: null or valid (only read for secondaries, where the spec reads it too).
    let Some(inheritance) = (unsafe { begin.p_inheritance_info.as_ref() }) else {
        return false;
    };
    // SAFETY: a valid pNext chain (the application's contract).
    unsafe {
        chain::find::<vk::CommandBufferInheritanceViewportScissorInfoNV<'_>>(inheritance.p_next)
    }
    .is_some_and(|info| info.viewport_scissor2_d == vk::TRUE)
}

/// The depth target a secondary command buffer continues (`crate::policy::inherited_target`,
/// from its inherited framebuffer's views, the pass and the format's images; a guess between
/// both kinds is logged once), after the application's convention.
/// The depth image of the subpass a secondary continues, where its inheritance names the
/// framebuffer (not an imageless one).
fn inherited_depth_image(
    entry: &CommandBufferEntry,
    inheritance: &vk::CommandBufferInheritanceInfo<'_>,
) -> Option<vk::Image> {
    let device = &entry.device;
    if inheritance.render_pass == vk::RenderPass::null()
        || inheritance.framebuffer == vk::Framebuffer::null()
    {
        return None;
    }
    let pass = device.objects.render_passes.get(&inheritance.render_pass)?;
    let index = pass
        .subpass_depth
        .get(inheritance.subpass as usize)
        .copied()
        .flatten()?;
    let views = attachment_views(device, inheritance.framebuffer, std::ptr::null());
    let view = views.get(index as usize)?;
    device.objects.views.get(view)
}

/// Infinite mode: whether the depth image of the subpass a secondary continues stores
/// complementary depth: from its inherited framebuffer where it names one; else from its
/// render pass (`crate::policy::DevicePolicy::secondary_stores_complementary`: where some
/// subpass references that attachment as an input attachment, of any aspect), assumed not
/// where that cannot tell (logged once, where the device has such images at all).
fn inherited_complementary(
    entry: &CommandBufferEntry,
    inheritance: &vk::CommandBufferInheritanceInfo<'_>,
) -> bool {
    let device = &entry.device;
    if inheritance.framebuffer != vk::Framebuffer::null() {
        return inherited_depth_image(entry, inheritance)
            .is_some_and(|image| device.stores_complementary(image));
    }
    let assumed = || {
        if !device.objects.complementary_images.is_empty() {
            static ASSUMED: crate::logging::LogOnce = crate::logging::LogOnce::new();
            ASSUMED.log(|| {
                log::warn!(
                    "infinite mode: a secondary command buffer continues a render pass without \
                     its framebuffer, or dynamic rendering, into a depth attachment revz cannot \
                     tell apart: assuming it stores n / w, not the complementary depth of \
                     images read as input attachments (a render pass that reads that \
                     attachment as an input, or the framebuffer in the inheritance info, tells)"
                )
            });
        }
        false
    };
    let Some(pass) = device.objects.render_passes.get(&inheritance.render_pass) else {
        // Dynamic rendering (no render pass) or an unknown one.
        return assumed();
    };
    let Some(depth) = pass
        .subpass_depth
        .get(inheritance.subpass as usize)
        .copied()
        .flatten()
    else {
        return false;
    };
    // Read as an input in any subpass, of any aspect: its image has the usage.
    let read_as_input = pass
        .input_attachments
        .get(depth as usize)
        .copied()
        .unwrap_or(false);
    device
        .policy
        .secondary_stores_complementary(read_as_input)
        .unwrap_or_else(assumed)
}

/// Whether a secondary continuing a subpass reads a reversed depth image through an input
/// attachment: from its inherited framebuffer where it names one; else assumed where the
/// policy reverses images read so (logged once).
fn inherited_reversed_inputs(
    entry: &CommandBufferEntry,
    inheritance: &vk::CommandBufferInheritanceInfo<'_>,
) -> bool {
    let device = &entry.device;
    if inheritance.render_pass == vk::RenderPass::null() {
        return false;
    }
    let Some(pass) = device.objects.render_passes.get(&inheritance.render_pass) else {
        return false;
    };
    let reads_depth = pass
        .subpass_depth_inputs
        .get(inheritance.subpass as usize)
        .is_some_and(|inputs| !inputs.is_empty());
    if !reads_depth {
        return false;
    }
    let views = attachment_views(device, inheritance.framebuffer, std::ptr::null());
    if views.is_empty() {
        static ASSUMED: OnceLock<()> = OnceLock::new();
        ASSUMED.get_or_init(|| {
            log::warn!(
                "a secondary command buffer without a framebuffer reads depth through an \
                 input attachment: assuming the image is reversed (as revz makes such images \
                 where it converts their reads)"
            )
        });
        return device.policy.converts_input_reads();
    }
    let scope = PassScope {
        handle: inheritance.render_pass,
        attachment_targets: views
            .iter()
            .map(|&view| device.observed.effective(device.view_target(view)))
            .collect(),
        render_pass: Some(pass),
        attachment_views: None,
        subpass: inheritance.subpass as usize,
        promoted: false,
        reversed_images: Vec::new(),
    };
    super::passes::reads_reversed_inputs(&scope)
}

pub(super) fn inherited_target(
    entry: &CommandBufferEntry,
    inheritance: &vk::CommandBufferInheritanceInfo<'_>,
) -> Target {
    let device = &entry.device;
    let (framebuffer, key, format) = if inheritance.render_pass != vk::RenderPass::null() {
        let pass = device.objects.render_passes.get(&inheritance.render_pass);
        // An imageless framebuffer names no views.
        let targets: Vec<Target> =
            attachment_views(device, inheritance.framebuffer, std::ptr::null())
                .iter()
                .map(|&view| device.view_target(view))
                .collect();
        let format = pass
            .as_deref()
            .and_then(|pass| subpass_depth_format(pass, inheritance.subpass));
        let framebuffer = (!targets.is_empty()).then(|| {
            PassScope {
                handle: inheritance.render_pass,
                render_pass: pass,
                attachment_targets: targets,
                attachment_views: None,
                subpass: inheritance.subpass as usize,
                promoted: false,
                reversed_images: Vec::new(),
            }
            .target()
        });
        (
            framebuffer,
            Some(SecondaryPass::Subpass(
                inheritance.render_pass,
                inheritance.subpass,
            )),
            format,
        )
    } else {
        // Dynamic rendering inheritance names only the formats.
        // SAFETY: a valid pNext chain (the application's contract).
        let format = unsafe {
            chain::find::<vk::CommandBufferInheritanceRenderingInfo<'_>>(inheritance.p_next)
        }
        .map(|info| info.depth_attachment_format)
        .filter(|&format| format != vk::Format::UNDEFINED);
        (None, format.map(SecondaryPass::Rendering), format)
    };
    static MIXED: OnceLock<()> = OnceLock::new();
    let (images, guessed) = crate::policy::inherited_target(
        framebuffer,
        format,
        || key.and_then(|key| device.objects.secondary_targets.get(&key)),
        |format| device.objects.count_images(format),
    );
    if guessed {
        MIXED.get_or_init(|| {
            log::warn!(
                "a secondary command buffer without a framebuffer draws into {:?}, which \
                 has both reversed and native images, in a pass not yet begun for secondaries: \
                 assuming reversed",
                format.unwrap_or_default()
            )
        });
    }
    device.observed.effective(images)
}

pub unsafe extern "system" fn cmd_execute_commands(
    buffer: vk::CommandBuffer,
    count: u32,
    p_buffers: *const vk::CommandBuffer,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdExecuteCommands");
    static MISMATCH: crate::logging::LogOnce = crate::logging::LogOnce::new();
    static CONVENTION: crate::logging::LogOnce = crate::logging::LogOnce::new();
    let device = with_entry(buffer, &ENTRY, |entry| {
        // Secondaries may write any image: the next refreshes cover everything again.
        super::twins::note_written_anything(entry);
        let mut state = entry.state();
        let target = state.target();
        let complementary = state.complementary_target();
        // A secondary decided its depth target at its begin; it can only be checked here.
        // SAFETY: `count` command buffers.
        for &secondary in unsafe { slice(p_buffers, count) } {
            if entry.device.profile.is_some() {
                if let Some(recorded) = objects::command_buffer(secondary) {
                    state.add_executed(&recorded.state());
                }
            }
            let recorded = objects::command_buffer(secondary);
            // Infinite mode: the camera the secondary's draws used last is the pass's now
            // (what the pass's images remember when it ends, `passes::remember_cameras`), where
            // the secondary knew one (not the device's last seen at its begin).
            if let Some(near_over_far) = recorded.as_ref().and_then(|s| s.state().camera()) {
                state.enter_camera(near_over_far);
            }
            if let Some(secondary) = &recorded {
                let stored = secondary.state().complementary_target();
                if entry.device.remembers_cameras()
                    && target == Target::Reversed
                    && stored != complementary
                {
                    CONVENTION.log(|| {
                        log::warn!(
                            "infinite mode: a secondary command buffer recorded for {} depth \
                             runs where the depth image stores {}: its depth does not match \
                             the pass's (give secondaries continuing a render pass their \
                             framebuffer in the inheritance info; draw into images read as \
                             input attachments from primaries where rendering is dynamic)",
                            if stored { "complementary" } else { "n / w" },
                            if complementary {
                                "complementary depth"
                            } else {
                                "n / w"
                            }
                        )
                    });
                }
            }
            let assumed = recorded.map(|s| s.state().inherited());
            if matches!(assumed, Some(a) if a != target && a != Target::None && target != Target::None)
            {
                MISMATCH.log(|| {
                    log::warn!(
                        "a secondary command buffer recorded for a {:?} depth attachment runs \
                         where the depth attachment is {target:?}: its depth state does not \
                         match (give secondaries their framebuffer in the inheritance info)",
                        assumed.unwrap_or_default()
                    )
                });
            }
        }
        // Secondaries may inherit the viewports set here; inside a subpass of secondaries
        // they went down at its begin, and nothing may be recorded there.
        if state.records_inline() {
            state.flush_viewports_for_secondaries(&mut NextLayer {
                device: &entry.device,
                buffer,
            });
        }
        state.invalidate();
    });
    if let Some(down) = &device {
        // SAFETY: calling down with the application's arguments.
        unsafe { (down.next.fp_v1_0().cmd_execute_commands)(buffer, count, p_buffers) };
        // The secondaries left the state undefined: what the next inline draw needs goes down.
        settle_down(&device, buffer);
    }
}

/// Whether a secondary's begin info inherits the primary's conditional rendering
/// (`VkCommandBufferInheritanceConditionalRenderingInfoEXT` with the flag set).
///
/// # Safety
/// `begin` must be a valid begin info of a secondary command buffer.
unsafe fn inherits_conditional_rendering(begin: &vk::CommandBufferBeginInfo<'_>) -> bool {
    // SAFETY: null or a valid inheritance info with a valid chain (the caller's contract).
    let Some(inheritance) = (unsafe { begin.p_inheritance_info.as_ref() }) else {
        return false;
    };
    // SAFETY: as above.
    let info = unsafe {
        crate::chain::find::<vk::CommandBufferInheritanceConditionalRenderingInfoEXT>(
            inheritance.p_next,
        )
    };
    info.is_some_and(|info| info.conditional_rendering_enable == vk::TRUE)
}
