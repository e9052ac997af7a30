//! When a read twin is refreshed (issue #39, `crate::depth_copy::twin`): the image barriers
//! and render pass instances that make a reversed image readable by shaders after it may have
//! been written. Pure functions of layouts, access masks and a render pass's attachment uses;
//! the hooks (`crate::hooks::command::twins`, `crate::hooks::render_pass`) hand them the facts.
//!
//! The rule that keeps refreshes to what was written: a twin is refreshed whenever its image
//! enters a layout shaders read from one that could have been written, so nothing needs
//! refreshing while the image leaves one read-only layout for another (nothing can write an
//! image in a read-only layout, and it was refreshed when it entered it).

use ash::vk;

/// Whether shaders may read an image in `layout` after a barrier whose second access scope
/// is `dst_access` (the raw bits of either API's flags: the sampled and shader reads share
/// their low bits; 0 where no barrier is involved, as at the end of a render pass).
pub fn shader_readable(layout: vk::ImageLayout, dst_access: u64) -> bool {
    let shader_reads = vk::AccessFlags2::SHADER_READ.as_raw()
        | vk::AccessFlags2::SHADER_SAMPLED_READ.as_raw()
        | vk::AccessFlags2::MEMORY_READ.as_raw();
    match layout {
        // The feedback loop layout (`VK_EXT_attachment_feedback_loop_layout`) is where an
        // image is attached and sampled at once: Zink generates depth mipmaps there, each
        // level drawn from the one above, with barriers within the layout between levels that
        // name attachment accesses only.
        vk::ImageLayout::DEPTH_READ_ONLY_STENCIL_ATTACHMENT_OPTIMAL
        | vk::ImageLayout::DEPTH_ATTACHMENT_STENCIL_READ_ONLY_OPTIMAL
        | vk::ImageLayout::ATTACHMENT_FEEDBACK_LOOP_OPTIMAL_EXT => true,
        vk::ImageLayout::GENERAL => dst_access & shader_reads != 0,
        other => read_only(other),
    }
}

/// Whether `layout` is one shaders read in which nothing can write either aspect of a depth
/// image (no attachment, transfer or storage write is allowed in it). The mixed layouts
/// (`DEPTH_READ_ONLY_STENCIL_ATTACHMENT_OPTIMAL` and its mirror) let one aspect be written,
/// and the twin holds both: they are not read-only here.
pub fn read_only(layout: vk::ImageLayout) -> bool {
    matches!(
        layout,
        vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL
            | vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL
            | vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL
            | vk::ImageLayout::STENCIL_READ_ONLY_OPTIMAL
            | vk::ImageLayout::READ_ONLY_OPTIMAL
    )
}

/// Whether an image barrier refreshes the twin: it makes the image readable by shaders
/// ([`shader_readable`]) after it may have been written: from a layout other than `UNDEFINED`
/// (whose contents nobody may read) and other than a read-only one (entered with a refresh,
/// and written by nothing since), into another layout or within one after writes; not a
/// queue family ownership transfer. Access masks are the raw bits of either API's flags.
pub fn barrier_refreshes(
    old: vk::ImageLayout,
    new: vk::ImageLayout,
    src_access: u64,
    dst_access: u64,
    (src_family, dst_family): (u32, u32),
) -> bool {
    let writes = vk::AccessFlags2::SHADER_WRITE.as_raw()
        | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw()
        | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw()
        | vk::AccessFlags2::TRANSFER_WRITE.as_raw()
        | vk::AccessFlags2::HOST_WRITE.as_raw()
        | vk::AccessFlags2::MEMORY_WRITE.as_raw()
        | vk::AccessFlags2::SHADER_STORAGE_WRITE.as_raw();
    let transfer_of_ownership = src_family != dst_family
        && src_family != vk::QUEUE_FAMILY_IGNORED
        && dst_family != vk::QUEUE_FAMILY_IGNORED;
    old != vk::ImageLayout::UNDEFINED
        && !read_only(old)
        && shader_readable(new, dst_access)
        && (old != new || src_access & writes != 0)
        && !transfer_of_ownership
}

/// How a render pass uses one of its attachments, as `vkCreateRenderPass*` describes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AttachmentUse {
    /// `initialLayout`.
    pub initial: vk::ImageLayout,
    /// `finalLayout`.
    pub final_layout: vk::ImageLayout,
    /// Whether its depth load op is `CLEAR`, a write at the start of the pass.
    pub depth_cleared: bool,
    /// Whether its stencil load op is `CLEAR` (where it has a stencil aspect).
    pub stencil_cleared: bool,
    /// The layout of each reference to it, in subpass order (input, color, resolve and
    /// depth-stencil references, and the separate stencil layout where one is given).
    pub references: Vec<vk::ImageLayout>,
    /// The stencil aspect's own initial and final layouts
    /// (`VkAttachmentDescriptionStencilLayout`), where given.
    pub stencil_layouts: Option<(vk::ImageLayout, vk::ImageLayout)>,
}

/// Where a render pass instance refreshes an attachment's twin.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassRefresh {
    /// Before the pass begins, with the image in this layout (its initial one): the pass's
    /// first use of it is a read-only layout, so shaders in the pass read it as it was when
    /// the pass began.
    pub at_begin: Option<vk::ImageLayout>,
    /// After the pass ends, with the image in this layout (its final one).
    pub at_end: Option<vk::ImageLayout>,
    /// Where the stencil aspect has layouts of its own: its refreshes (before, after), apart
    /// from the depth aspect's (`at_begin`, `at_end` then concern the depth aspect only).
    pub stencil_apart: Option<(Option<vk::ImageLayout>, Option<vk::ImageLayout>)>,
}

/// When a render pass instance refreshes twins: before it begins, or after it ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassMoment {
    Begin,
    End,
}

impl PassRefresh {
    /// The refreshes at `moment`, as (aspects, layout the image is in): all of the view's
    /// aspects at once, or depth and stencil apart where the stencil has its own layouts.
    pub fn at(&self, moment: PassMoment) -> [Option<(vk::ImageAspectFlags, vk::ImageLayout)>; 2] {
        let pick = |(begin, end): (Option<vk::ImageLayout>, Option<vk::ImageLayout>)| match moment {
            PassMoment::Begin => begin,
            PassMoment::End => end,
        };
        let depth = pick((self.at_begin, self.at_end));
        match self.stencil_apart {
            None => [
                depth.map(|layout| {
                    (
                        vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
                        layout,
                    )
                }),
                None,
            ],
            Some(stencil) => [
                depth.map(|layout| (vk::ImageAspectFlags::DEPTH, layout)),
                pick(stencil).map(|layout| (vk::ImageAspectFlags::STENCIL, layout)),
            ],
        }
    }
}

impl AttachmentUse {
    /// Where the pass refreshes the twin of this attachment's image.
    ///
    /// At the begin: where the first subpass that uses it reads it in a read-only layout it
    /// was not already in, from a layout it may have been written in (no refresh inside a
    /// pass is possible, and its implicit transition makes it readable there). At the end:
    /// where the final layout is one shaders read and the pass may have written it (a clear,
    /// a reference in a layout other than a read-only one), or it leaves a layout it may
    /// have been written in without a refresh at the begin (an attachment no subpass uses).
    /// Where the stencil has layouts of its own, its aspect follows the same rules with them
    /// (and its own clear).
    pub fn refreshes(&self) -> PassRefresh {
        let (at_begin, at_end) =
            self.refreshes_between(self.initial, self.final_layout, self.depth_cleared);
        let stencil_apart = self
            .stencil_layouts
            .filter(|&layouts| layouts != (self.initial, self.final_layout))
            .map(|(initial, final_layout)| {
                self.refreshes_between(initial, final_layout, self.stencil_cleared)
            });
        PassRefresh {
            at_begin,
            at_end,
            stencil_apart,
        }
    }

    /// (before, after) for an aspect entering the pass in `initial` and leaving it in
    /// `final_layout`, cleared at the begin where `cleared`.
    fn refreshes_between(
        &self,
        initial: vk::ImageLayout,
        final_layout: vk::ImageLayout,
        cleared: bool,
    ) -> (Option<vk::ImageLayout>, Option<vk::ImageLayout>) {
        let writable_before = initial != vk::ImageLayout::UNDEFINED && !read_only(initial);
        let first_use = self.references.first().copied();
        let at_begin = (writable_before
            && !cleared
            && first_use.is_some_and(|layout| read_only(layout) || layout_reads_depth(layout)))
        .then_some(initial);
        let written = self.depth_cleared
            || self.stencil_cleared
            || self.references.iter().any(|&layout| !read_only(layout));
        let unrefreshed_before = writable_before && first_use.is_none();
        let at_end = (shader_readable(final_layout, 0) || final_layout == vk::ImageLayout::GENERAL)
            .then_some(final_layout)
            .filter(|_| written || unrefreshed_before);
        (at_begin, at_end)
    }
}

impl AttachmentUse {
    /// Whether a subpass uses the attachment in a layout shaders may read it in after an
    /// earlier subpass of the same pass may have written it: shaders sampling it there read
    /// its twin as it was when the pass began (no refresh can be recorded inside a pass).
    pub fn read_after_written_inside(&self) -> bool {
        let mut written = self.depth_cleared || self.stencil_cleared;
        for &layout in &self.references {
            let readable = shader_readable(layout, 0) || layout == vk::ImageLayout::GENERAL;
            if written && readable {
                return true;
            }
            written |= !read_only(layout);
        }
        false
    }
}

/// Whether the depth aspect is read-only in `layout` while the stencil may be written (a
/// pass sampling depth while testing stencil): the depth shaders read must be refreshed at
/// the begin, and the stencil written makes the end refresh too.
fn layout_reads_depth(layout: vk::ImageLayout) -> bool {
    layout == vk::ImageLayout::DEPTH_READ_ONLY_STENCIL_ATTACHMENT_OPTIMAL
}

/// What one command buffer has refreshed of its images' twins and not written since: a later
/// refresh there skips those subresources (issue #39: refresh only what was written). Only the
/// command buffer's own commands are known, so a subresource it has not refreshed itself counts
/// as written (it may have been before the recording began, or by a secondary it executed).
///
/// A refresh keeps the aspects its barrier names (a depth/stencil image's layout transitions
/// name both, unless separate layouts are enabled) and narrows its mip levels and layers to the
/// smallest box around those still to refresh: a cube map drawn face by face, each face followed
/// by a barrier of all six, refreshes six faces at the first barrier and one at each later one.
#[derive(Clone, Debug, Default)]
pub struct RefreshLedger {
    images: Vec<(vk::Image, CleanSubresources)>,
}

/// The subresources of one image refreshed since they were last written: a bit per aspect
/// (depth, stencil), mip level and array layer.
#[derive(Clone, Debug)]
struct CleanSubresources {
    levels: u32,
    layers: u32,
    bits: Vec<u64>,
}

impl CleanSubresources {
    fn new(levels: u32, layers: u32) -> CleanSubresources {
        let count = 2 * levels as usize * layers as usize;
        CleanSubresources {
            levels,
            layers,
            bits: vec![0; count.div_ceil(64)],
        }
    }

    /// The bit indices of `range`'s depth and stencil subresources (counts resolved against
    /// the image; empty past its end).
    fn indices(
        &self,
        range: vk::ImageSubresourceRange,
    ) -> impl Iterator<Item = (usize, u32, u32)> + '_ {
        let resolve = |base: u32, count: u32, total: u32| {
            let end = if count == vk::REMAINING_MIP_LEVELS {
                total
            } else {
                base.saturating_add(count).min(total)
            };
            base.min(end)..end
        };
        let levels = resolve(range.base_mip_level, range.level_count, self.levels);
        let layers = resolve(range.base_array_layer, range.layer_count, self.layers);
        let aspects = [vk::ImageAspectFlags::DEPTH, vk::ImageAspectFlags::STENCIL]
            .into_iter()
            .enumerate()
            .filter(move |(_, aspect)| range.aspect_mask.contains(*aspect))
            .map(|(index, _)| index);
        let (levels_total, layers_total) = (self.levels as usize, self.layers as usize);
        aspects.flat_map(move |aspect| {
            let layers = layers.clone();
            levels.clone().flat_map(move |level| {
                layers.clone().map(move |layer| {
                    let index =
                        (aspect * levels_total + level as usize) * layers_total + layer as usize;
                    (index, level, layer)
                })
            })
        })
    }

    fn is_clean(&self, index: usize) -> bool {
        self.bits[index / 64] & (1 << (index % 64)) != 0
    }

    fn set(&mut self, index: usize, clean: bool) {
        let bit = 1 << (index % 64);
        if clean {
            self.bits[index / 64] |= bit;
        } else {
            self.bits[index / 64] &= !bit;
        }
    }
}

impl RefreshLedger {
    /// What of `range` (of `image`) a refresh must still cover: `range` narrowed to the mip
    /// levels and layers around the subresources not refreshed since written (its aspects
    /// kept), `None` where every one is.
    pub fn to_refresh(
        &self,
        image: vk::Image,
        range: vk::ImageSubresourceRange,
    ) -> Option<vk::ImageSubresourceRange> {
        let Some((_, clean)) = self.images.iter().find(|(i, _)| *i == image) else {
            return Some(range);
        };
        let mut levels = (u32::MAX, 0);
        let mut layers = (u32::MAX, 0);
        for (index, level, layer) in clean.indices(range) {
            if !clean.is_clean(index) {
                levels = (levels.0.min(level), levels.1.max(level + 1));
                layers = (layers.0.min(layer), layers.1.max(layer + 1));
            }
        }
        (levels.0 < levels.1).then(|| vk::ImageSubresourceRange {
            base_mip_level: levels.0,
            level_count: levels.1 - levels.0,
            base_array_layer: layers.0,
            layer_count: layers.1 - layers.0,
            ..range
        })
    }

    /// `range` of `image` (of `levels` x `layers`) was refreshed.
    pub fn refreshed(
        &mut self,
        image: vk::Image,
        range: vk::ImageSubresourceRange,
        (levels, layers): (u32, u32),
    ) {
        let position = match self.images.iter().position(|(i, _)| *i == image) {
            Some(position) => position,
            None => {
                self.images
                    .push((image, CleanSubresources::new(levels, layers)));
                self.images.len() - 1
            }
        };
        let clean = &mut self.images[position].1;
        let indices: Vec<usize> = clean.indices(range).map(|(index, ..)| index).collect();
        for index in indices {
            clean.set(index, true);
        }
    }

    /// `range` of `image` may have been written (an attachment of a render pass begun).
    pub fn written(&mut self, image: vk::Image, range: vk::ImageSubresourceRange) {
        if let Some((_, clean)) = self.images.iter_mut().find(|(i, _)| *i == image) {
            let indices: Vec<usize> = clean.indices(range).map(|(index, ..)| index).collect();
            for index in indices {
                clean.set(index, false);
            }
        }
    }

    /// Any subresource of `image` may have been written (a transfer into it).
    pub fn written_all(&mut self, image: vk::Image) {
        self.images.retain(|(i, _)| *i != image);
    }

    /// Anything may have been written (secondaries executed, a new recording).
    pub fn forget(&mut self) {
        self.images.clear();
    }

    /// Whether nothing is known clean (then writes need not be noted).
    pub fn is_empty(&self) -> bool {
        self.images.is_empty()
    }
}

#[cfg(test)]
mod tests {
    /// A range as a comparable tuple (ash's has no `PartialEq`).
    fn key(
        range: Option<vk::ImageSubresourceRange>,
    ) -> Option<(vk::ImageAspectFlags, u32, u32, u32, u32)> {
        range.map(|r| {
            (
                r.aspect_mask,
                r.base_mip_level,
                r.level_count,
                r.base_array_layer,
                r.layer_count,
            )
        })
    }

    #[test]
    fn a_ledger_narrows_refreshes_to_what_was_written_since() {
        use vk::Handle;
        let image = vk::Image::from_raw(7);
        let both = vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL;
        let all = vk::ImageSubresourceRange {
            aspect_mask: both,
            base_mip_level: 0,
            level_count: vk::REMAINING_MIP_LEVELS,
            base_array_layer: 0,
            layer_count: vk::REMAINING_ARRAY_LAYERS,
        };
        let face = |layer: u32| vk::ImageSubresourceRange {
            base_array_layer: layer,
            layer_count: 1,
            level_count: 1,
            ..all
        };
        let mut ledger = RefreshLedger::default();
        // Nothing known: the whole range.
        assert_eq!(key(ledger.to_refresh(image, all)), key(Some(all)));
        ledger.refreshed(image, all, (1, 6));
        assert!(!ledger.is_empty());
        // Refreshed and not written since: nothing.
        assert_eq!(key(ledger.to_refresh(image, all)), None);
        // A face drawn: that face alone, with the barrier's aspects.
        ledger.written(image, face(3));
        assert_eq!(key(ledger.to_refresh(image, all)), key(Some(face(3))));
        // Two faces: the box around them.
        ledger.written(image, face(1));
        assert_eq!(key(ledger.to_refresh(image, all)), Some((both, 0, 1, 1, 3)));
        // A barrier naming a clean face refreshes nothing.
        assert_eq!(key(ledger.to_refresh(image, face(0))), None);
        ledger.refreshed(image, all, (1, 6));
        assert_eq!(key(ledger.to_refresh(image, all)), None);
        // The stencil written alone (separate layouts): a depth barrier still has nothing,
        // a stencil one has that layer.
        let stencil = vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::STENCIL,
            ..face(2)
        };
        ledger.written(image, stencil);
        let only = |aspect_mask| vk::ImageSubresourceRange { aspect_mask, ..all };
        assert_eq!(
            key(ledger.to_refresh(image, only(vk::ImageAspectFlags::DEPTH))),
            None
        );
        assert_eq!(
            key(ledger.to_refresh(image, only(vk::ImageAspectFlags::STENCIL))),
            key(Some(stencil))
        );
        // A transfer into it, or executed secondaries: everything again.
        ledger.written_all(image);
        assert_eq!(key(ledger.to_refresh(image, all)), key(Some(all)));
        ledger.refreshed(image, all, (1, 6));
        ledger.forget();
        assert_eq!(key(ledger.to_refresh(image, all)), key(Some(all)));
        // Another image is unaffected by this one's entries.
        ledger.refreshed(image, all, (1, 6));
        assert_eq!(
            key(ledger.to_refresh(vk::Image::from_raw(8), all)),
            key(Some(all))
        );
    }

    #[test]
    fn a_ledger_tracks_mip_levels_apart() {
        use vk::Handle;
        let image = vk::Image::from_raw(9);
        let level = |level: u32| vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::DEPTH,
            base_mip_level: level,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 2,
        };
        let chain = vk::ImageSubresourceRange {
            level_count: 4,
            ..level(0)
        };
        let mut ledger = RefreshLedger::default();
        ledger.refreshed(image, chain, (4, 2));
        ledger.written(image, level(2));
        assert_eq!(key(ledger.to_refresh(image, chain)), key(Some(level(2))));
        // Ranges past the image's end cover nothing there.
        let past = vk::ImageSubresourceRange {
            base_mip_level: 5,
            ..level(0)
        };
        assert_eq!(key(ledger.to_refresh(image, past)), None);
    }

    use super::*;
    use vk::ImageLayout as L;

    const SAME: (u32, u32) = (vk::QUEUE_FAMILY_IGNORED, vk::QUEUE_FAMILY_IGNORED);

    fn raw(access: vk::AccessFlags) -> u64 {
        u64::from(access.as_raw())
    }

    #[test]
    fn barriers_refresh_transitions_into_layouts_shaders_read() {
        let write = raw(vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE);
        let read = raw(vk::AccessFlags::SHADER_READ);
        // The usual: attachment to sampled, to read-only attachment.
        assert!(barrier_refreshes(
            L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
            L::SHADER_READ_ONLY_OPTIMAL,
            write,
            read,
            SAME
        ));
        assert!(barrier_refreshes(
            L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
            L::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
            write,
            read,
            SAME
        ));
        assert!(barrier_refreshes(
            L::TRANSFER_DST_OPTIMAL,
            L::SHADER_READ_ONLY_OPTIMAL,
            raw(vk::AccessFlags::TRANSFER_WRITE),
            read,
            SAME
        ));
        // Stencil written in a mixed layout: the twin's stencil changed.
        assert!(barrier_refreshes(
            L::DEPTH_READ_ONLY_STENCIL_ATTACHMENT_OPTIMAL,
            L::SHADER_READ_ONLY_OPTIMAL,
            write,
            read,
            SAME
        ));
        // The feedback loop layout (Zink's depth mipmaps): entered, and within it after each
        // level's writes, whatever the barrier says comes next; not without writes.
        let feedback = L::ATTACHMENT_FEEDBACK_LOOP_OPTIMAL_EXT;
        let attachment = raw(vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ);
        assert!(barrier_refreshes(
            L::TRANSFER_SRC_OPTIMAL,
            feedback,
            raw(vk::AccessFlags::TRANSFER_WRITE),
            attachment,
            SAME
        ));
        assert!(barrier_refreshes(
            feedback, feedback, write, attachment, SAME
        ));
        assert!(!barrier_refreshes(
            feedback, feedback, attachment, attachment, SAME
        ));
        // GENERAL only when shaders read after it.
        assert!(barrier_refreshes(L::GENERAL, L::GENERAL, write, read, SAME));
        assert!(!barrier_refreshes(
            L::GENERAL,
            L::GENERAL,
            write,
            raw(vk::AccessFlags::TRANSFER_READ),
            SAME
        ));
    }

    #[test]
    fn barriers_refresh_nothing_unwritten_unreadable_or_transferred() {
        let write = raw(vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE);
        let read = raw(vk::AccessFlags::SHADER_READ);
        // Not readable afterwards.
        assert!(!barrier_refreshes(
            L::SHADER_READ_ONLY_OPTIMAL,
            L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
            read,
            write,
            SAME
        ));
        // Undefined contents.
        assert!(!barrier_refreshes(
            L::UNDEFINED,
            L::SHADER_READ_ONLY_OPTIMAL,
            0,
            read,
            SAME
        ));
        // From one read-only layout to another (soft particles, then a post pass): nothing
        // wrote it since it entered the first, where it was refreshed.
        for old in [
            L::SHADER_READ_ONLY_OPTIMAL,
            L::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
            L::DEPTH_READ_ONLY_OPTIMAL,
            L::READ_ONLY_OPTIMAL,
        ] {
            for new in [
                L::SHADER_READ_ONLY_OPTIMAL,
                L::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
            ] {
                assert!(!barrier_refreshes(old, new, write, read, SAME), "{old:?}");
            }
        }
        // An ownership transfer.
        assert!(!barrier_refreshes(
            L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
            L::SHADER_READ_ONLY_OPTIMAL,
            write,
            read,
            (0, 1)
        ));
    }

    fn attachment(initial: L, cleared: bool, references: &[L], final_layout: L) -> PassRefresh {
        AttachmentUse {
            initial,
            final_layout,
            depth_cleared: cleared,
            stencil_cleared: false,
            references: references.to_vec(),
            stencil_layouts: None,
        }
        .refreshes()
    }

    #[test]
    fn passes_refresh_at_the_end_what_they_may_have_written() {
        // A shadow pass: cleared, written, left sampled.
        assert_eq!(
            attachment(
                L::UNDEFINED,
                true,
                &[L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL],
                L::SHADER_READ_ONLY_OPTIMAL
            ),
            PassRefresh {
                at_begin: None,
                at_end: Some(L::SHADER_READ_ONLY_OPTIMAL),
                stencil_apart: None,
            }
        );
        // A main pass left as an attachment: nothing shaders read.
        assert_eq!(
            attachment(
                L::UNDEFINED,
                true,
                &[L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL],
                L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL
            ),
            PassRefresh::default()
        );
        // Written in a subpass, read in the next (input attachment), left sampled.
        assert_eq!(
            attachment(
                L::UNDEFINED,
                true,
                &[
                    L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                    L::DEPTH_STENCIL_READ_ONLY_OPTIMAL
                ],
                L::SHADER_READ_ONLY_OPTIMAL
            )
            .at_end,
            Some(L::SHADER_READ_ONLY_OPTIMAL)
        );
        // In no subpass: left readable from a layout it may have been written in.
        assert_eq!(
            attachment(
                L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                false,
                &[],
                L::SHADER_READ_ONLY_OPTIMAL
            ),
            PassRefresh {
                at_begin: None,
                at_end: Some(L::SHADER_READ_ONLY_OPTIMAL),
                stencil_apart: None,
            }
        );
    }

    /// `VK_KHR_separate_depth_stencil_layouts`: a depth aspect left sampled while the stencil
    /// stays an attachment is refreshed alone, in its own layout; the stencil's aspect with
    /// its own layouts where they call for it.
    #[test]
    fn separate_stencil_layouts_refresh_each_aspect_in_its_own_layout() {
        let used = AttachmentUse {
            initial: L::UNDEFINED,
            final_layout: L::DEPTH_READ_ONLY_OPTIMAL,
            depth_cleared: true,
            stencil_cleared: true,
            references: vec![L::DEPTH_ATTACHMENT_OPTIMAL, L::STENCIL_ATTACHMENT_OPTIMAL],
            stencil_layouts: Some((L::UNDEFINED, L::STENCIL_ATTACHMENT_OPTIMAL)),
        };
        let refresh = used.refreshes();
        assert_eq!(
            refresh.at(PassMoment::End),
            [
                Some((vk::ImageAspectFlags::DEPTH, L::DEPTH_READ_ONLY_OPTIMAL)),
                None
            ]
        );
        assert_eq!(refresh.at(PassMoment::Begin), [None, None]);
        let both_sampled = AttachmentUse {
            stencil_layouts: Some((L::UNDEFINED, L::STENCIL_READ_ONLY_OPTIMAL)),
            ..used.clone()
        };
        assert_eq!(
            both_sampled.refreshes().at(PassMoment::End),
            [
                Some((vk::ImageAspectFlags::DEPTH, L::DEPTH_READ_ONLY_OPTIMAL)),
                Some((vk::ImageAspectFlags::STENCIL, L::STENCIL_READ_ONLY_OPTIMAL))
            ]
        );
        // Stencil layouts equal to the depth's: one refresh of every aspect.
        let same = AttachmentUse {
            final_layout: L::SHADER_READ_ONLY_OPTIMAL,
            stencil_layouts: Some((L::UNDEFINED, L::SHADER_READ_ONLY_OPTIMAL)),
            ..used
        };
        assert_eq!(
            same.refreshes().at(PassMoment::End),
            [
                Some((
                    vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
                    L::SHADER_READ_ONLY_OPTIMAL
                )),
                None
            ]
        );
    }

    #[test]
    fn reads_after_writes_inside_a_pass_are_found() {
        let used = |cleared, references: &[L]| AttachmentUse {
            initial: L::UNDEFINED,
            final_layout: L::SHADER_READ_ONLY_OPTIMAL,
            depth_cleared: cleared,
            stencil_cleared: false,
            references: references.to_vec(),
            stencil_layouts: None,
        };
        // A depth pre-pass, then a subpass testing it read-only (where it may be sampled).
        assert!(used(
            true,
            &[
                L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                L::DEPTH_STENCIL_READ_ONLY_OPTIMAL
            ]
        )
        .read_after_written_inside());
        // Cleared, then read-only at once.
        assert!(used(true, &[L::DEPTH_STENCIL_READ_ONLY_OPTIMAL]).read_after_written_inside());
        // Written in every subpass, or only read: nothing read after a write inside.
        assert!(!used(
            true,
            &[
                L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL
            ]
        )
        .read_after_written_inside());
        assert!(!used(false, &[L::DEPTH_STENCIL_READ_ONLY_OPTIMAL]).read_after_written_inside());
    }

    #[test]
    fn passes_that_read_their_depth_refresh_it_at_the_begin_only() {
        // Soft particles: the main depth loaded read-only while it is sampled, left sampled.
        assert_eq!(
            attachment(
                L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                false,
                &[L::DEPTH_STENCIL_READ_ONLY_OPTIMAL],
                L::SHADER_READ_ONLY_OPTIMAL
            ),
            PassRefresh {
                at_begin: Some(L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL),
                at_end: None,
                stencil_apart: None,
            }
        );
        // Already read-only when the pass begins: refreshed when it entered that layout.
        assert_eq!(
            attachment(
                L::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
                false,
                &[L::DEPTH_STENCIL_READ_ONLY_OPTIMAL],
                L::DEPTH_STENCIL_READ_ONLY_OPTIMAL
            ),
            PassRefresh::default()
        );
        // Depth read while the stencil is written: both ends.
        assert_eq!(
            attachment(
                L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                false,
                &[L::DEPTH_READ_ONLY_STENCIL_ATTACHMENT_OPTIMAL],
                L::SHADER_READ_ONLY_OPTIMAL
            ),
            PassRefresh {
                at_begin: Some(L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL),
                at_end: Some(L::SHADER_READ_ONLY_OPTIMAL),
                stencil_apart: None,
            }
        );
        // The same with the stencil cleared (light volumes marked in the stencil): the depth
        // loaded is read.
        let stencil_marked = AttachmentUse {
            initial: L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
            final_layout: L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
            depth_cleared: false,
            stencil_cleared: true,
            references: vec![L::DEPTH_READ_ONLY_STENCIL_ATTACHMENT_OPTIMAL],
            stencil_layouts: None,
        };
        assert_eq!(
            stencil_marked.refreshes(),
            PassRefresh {
                at_begin: Some(L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL),
                at_end: None,
                stencil_apart: None,
            }
        );
        // Written first: nothing to read at the begin.
        assert_eq!(
            attachment(
                L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                false,
                &[
                    L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                    L::DEPTH_STENCIL_READ_ONLY_OPTIMAL
                ],
                L::DEPTH_STENCIL_ATTACHMENT_OPTIMAL
            ),
            PassRefresh::default()
        );
        // Fresh contents are nobody's to read.
        assert_eq!(
            attachment(
                L::UNDEFINED,
                false,
                &[L::DEPTH_STENCIL_READ_ONLY_OPTIMAL],
                L::SHADER_READ_ONLY_OPTIMAL
            ),
            PassRefresh::default()
        );
    }
}
