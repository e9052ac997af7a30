//! What revz last sent down for each depth-related dynamic state, and the sink that drops a
//! call that would send those values again (`Filtered`): every settle re-evaluates the state,
//! and only what changed goes down.

use ash::vk;

use super::{StateSink, States, MAX_VIEWPORTS};
use crate::conv::DepthBias;
use crate::precise::PushSink;

/// What revz last sent down for each depth-related dynamic state, so that a draw whose state
/// was re-evaluated (a pipeline bind, a push that changed the path) sends only what changed: on
/// a driver that records every `vkCmdSet*` as a command, redundant ones cost as much as the
/// layer's own work.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Emitted {
    /// The last viewport call.
    pub(super) viewports: Option<SentViewports>,
    pub(super) compare_op: Option<vk::CompareOp>,
    pub(super) bias: Option<DepthBias>,
    pub(super) bounds: Option<(u32, u32)>,
    pub(super) clip_negative_one_to_one: Option<bool>,
    /// The last clamp range call: `Some(None)` the viewport's range, `Some(Some(bits))` a
    /// user-defined one.
    pub(super) clamp_range: Option<Option<(u32, u32)>>,
}

impl Emitted {
    /// Forgets the states a newly bound pipeline sets statically (binding it overwrites them).
    pub(super) fn forget_static(&mut self, dynamic: States) {
        if !dynamic.intersects(States::VIEWPORT | States::VIEWPORT_WITH_COUNT) {
            self.viewports = None;
        }
        if !dynamic.contains(States::COMPARE_OP) {
            self.compare_op = None;
        }
        if !dynamic.contains(States::BIAS) {
            self.bias = None;
        }
        if !dynamic.contains(States::BOUNDS) {
            self.bounds = None;
        }
        if !dynamic.contains(States::CLIP_CONTROL) {
            self.clip_negative_one_to_one = None;
        }
        if !dynamic.contains(States::CLAMP_RANGE) {
            self.clamp_range = None;
        }
    }
}

/// A viewport call as sent: with count or not, the first viewport, and the bits of the
/// viewports (only the first `count` entries of `bits` mean anything). Compared and written
/// for the viewports sent only: a settle runs at every bind.
#[derive(Clone, Copy, Debug)]
pub(super) struct SentViewports {
    pub(super) with_count: bool,
    pub(super) first: u32,
    pub(super) count: u32,
    pub(super) bits: [[u32; 6]; MAX_VIEWPORTS],
}

pub(super) fn viewport_bits(v: &vk::Viewport) -> [u32; 6] {
    [v.x, v.y, v.width, v.height, v.min_depth, v.max_depth].map(f32::to_bits)
}

impl SentViewports {
    pub(super) fn is(&self, with_count: bool, first: u32, viewports: &[vk::Viewport]) -> bool {
        self.with_count == with_count
            && self.first == first
            && self.count as usize == viewports.len()
            && self
                .bits
                .iter()
                .zip(viewports)
                .all(|(bits, v)| *bits == viewport_bits(v))
    }

    /// Records the call in `slot`, unless it is the one recorded: whether it must be sent.
    pub(super) fn record(
        slot: &mut Option<SentViewports>,
        with_count: bool,
        first: u32,
        viewports: &[vk::Viewport],
    ) -> bool {
        if slot
            .as_ref()
            .is_some_and(|sent| sent.is(with_count, first, viewports))
        {
            return false;
        }
        let sent = slot.get_or_insert(SentViewports {
            with_count,
            first,
            count: 0,
            bits: [[0; 6]; MAX_VIEWPORTS],
        });
        sent.with_count = with_count;
        sent.first = first;
        sent.count = viewports.len().min(MAX_VIEWPORTS) as u32;
        for (bits, v) in sent.bits.iter_mut().zip(viewports) {
            *bits = viewport_bits(v);
        }
        true
    }
}

/// A [`StateSink`] that drops what would re-send the values last sent.
pub(super) struct Filtered<'a, S> {
    pub(super) sink: &'a mut S,
    pub(super) last: &'a mut Emitted,
}

impl<S: StateSink> PushSink for Filtered<'_, S> {
    fn push_constants(
        &mut self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        bytes: &[u8],
    ) {
        self.sink.push_constants(layout, stages, offset, bytes);
    }
}

impl<S: StateSink> StateSink for Filtered<'_, S> {
    fn set_viewports(&mut self, first: u32, viewports: &[vk::Viewport]) {
        if SentViewports::record(&mut self.last.viewports, false, first, viewports) {
            self.sink.set_viewports(first, viewports);
        }
    }

    fn set_viewports_with_count(&mut self, viewports: &[vk::Viewport]) {
        if SentViewports::record(&mut self.last.viewports, true, 0, viewports) {
            self.sink.set_viewports_with_count(viewports);
        }
    }

    fn set_compare_op(&mut self, op: vk::CompareOp) {
        if self.last.compare_op != Some(op) {
            self.last.compare_op = Some(op);
            self.sink.set_compare_op(op);
        }
    }

    fn set_bias(&mut self, bias: DepthBias) {
        if self.last.bias != Some(bias) {
            self.last.bias = Some(bias);
            self.sink.set_bias(bias);
        }
    }

    fn set_bounds(&mut self, min: f32, max: f32) {
        let bits = (min.to_bits(), max.to_bits());
        if self.last.bounds != Some(bits) {
            self.last.bounds = Some(bits);
            self.sink.set_bounds(min, max);
        }
    }

    fn set_clip_negative_one_to_one(&mut self, negative_one_to_one: bool) {
        if self.last.clip_negative_one_to_one != Some(negative_one_to_one) {
            self.last.clip_negative_one_to_one = Some(negative_one_to_one);
            self.sink.set_clip_negative_one_to_one(negative_one_to_one);
        }
    }

    fn set_clamp_range(&mut self, range: Option<(f32, f32)>) {
        let bits = range.map(|(min, max)| (min.to_bits(), max.to_bits()));
        if self.last.clamp_range != Some(bits) {
            self.last.clamp_range = Some(bits);
            self.sink.set_clamp_range(range);
        }
    }

    fn bind_pipeline(&mut self, pipeline: vk::Pipeline) {
        // A variant has the dynamic states of the pipeline it stands for: binding it
        // overwrites nothing the record holds.
        self.sink.bind_pipeline(pipeline);
    }

    fn bind_shader(&mut self, stage: vk::ShaderStageFlags, shader: vk::ShaderEXT) {
        // Shader objects have no static state.
        self.sink.bind_shader(stage, shader);
    }
}
