//! The viewports the application set in a command buffer, and how they go down for a draw's
//! path.

use ash::vk;

use super::{DrawPath, PipelineDepth, StateSink, States, MAX_VIEWPORTS};
use crate::conv::Reversal;

/// The viewports the application set in a command buffer.
#[derive(Clone, Copy, Debug)]
pub(super) struct AppViewports {
    pub(super) values: [vk::Viewport; MAX_VIEWPORTS],
    /// Which of `values` were set with `vkCmdSetViewport`.
    pub(super) set: u16,
    /// The count of `vkCmdSetViewportWithCount`, if the application used it.
    pub(super) count: Option<u32>,
}

impl Default for AppViewports {
    fn default() -> Self {
        AppViewports {
            values: [vk::Viewport::default(); MAX_VIEWPORTS],
            set: 0,
            count: None,
        }
    }
}

impl AppViewports {
    /// Sends the viewports of a draw on `path`: the application's (`from_app` says which
    /// kind it set: with count, or by index), else the pipeline's static ones that revz made
    /// dynamic.
    pub(super) fn emit(
        &self,
        sink: &mut impl StateSink,
        path: DrawPath,
        reversal: Reversal,
        from_app: States,
        pipeline: Option<&PipelineDepth>,
    ) {
        let viewport = |v: &vk::Viewport| match path {
            DrawPath::Native => *v,
            DrawPath::Flip => reversal.viewport(*v),
            DrawPath::Precise => reversal.precise_viewport(*v),
        };
        if from_app.contains(States::VIEWPORT_WITH_COUNT) {
            let count = self.count.unwrap_or(0) as usize;
            let mut out = [vk::Viewport::default(); MAX_VIEWPORTS];
            for (o, v) in out.iter_mut().zip(&self.values[..count]) {
                *o = viewport(v);
            }
            sink.set_viewports_with_count(&out[..count]);
        } else if from_app.contains(States::VIEWPORT) {
            // Emit each contiguous run of viewports the application set.
            let mut index = 0;
            while index < MAX_VIEWPORTS {
                if self.set & (1 << index) == 0 {
                    index += 1;
                    continue;
                }
                let start = index;
                let mut out = [vk::Viewport::default(); MAX_VIEWPORTS];
                while index < MAX_VIEWPORTS && self.set & (1 << index) != 0 {
                    out[index - start] = viewport(&self.values[index]);
                    index += 1;
                }
                sink.set_viewports(start as u32, &out[..index - start]);
            }
        } else if let Some(p) = pipeline.filter(|p| p.injected.contains(States::VIEWPORT)) {
            let mut out = [vk::Viewport::default(); MAX_VIEWPORTS];
            let count = p.viewports.len().min(MAX_VIEWPORTS);
            for (o, v) in out.iter_mut().zip(&p.viewports[..count]) {
                *o = viewport(v);
            }
            sink.set_viewports(0, &out[..count]);
        }
    }
}
