//! [`Plan::check`]: every rule the renderer relies on, stated over the plan before any Vulkan
//! call (indices in range, passes balanced, pipelines used in their own pass and subpass,
//! dynamic state set before the draws that need it).

use super::*;

/// Recording state tracked by [`Plan::check`]: what the Vulkan validity rules depend on.
#[derive(Clone, Debug, Default)]
struct CheckState {
    /// The current pass and subpass.
    pass: Option<(usize, u32)>,
    /// The bound pipeline (in this command buffer).
    pipeline: Option<usize>,
    /// Dynamic states set since that pipeline was bound: compare op, bias, bounds, viewport.
    set: [bool; 4],
    /// The current subpass records secondaries (`Some(true)`) or inline commands.
    secondary_subpass: Option<bool>,
    /// Which 4-byte words of push constants have been written in this command buffer, and
    /// for which push-constant size (binding a pipeline of another size forgets them).
    pushed: (u32, u32),
}

impl Plan {
    /// Checks every rule the renderer relies on; `objects` is the scene's object count and
    /// `has_light` whether it has a light (needed by shadow passes).
    pub fn check(&self, objects: usize, has_light: bool) -> Result<(), PlanError> {
        // The renderer has one second primary to resume a rendering in, begun once.
        let across = self
            .steps
            .iter()
            .filter(|step| match step {
                Step::BeginPass(n) => self.passes.get(*n).is_some_and(|p| {
                    p.kind
                        == PassKind::DynamicRenderingSuspended {
                            across_command_buffers: true,
                        }
                }),
                _ => false,
            })
            .count();
        ensure!(
            across <= 1,
            "{across} renderings resume in a second primary command buffer (at most one)"
        );
        for (i, pipeline) in self.pipelines.iter().enumerate() {
            let name = pipeline.name;
            let pass = self.passes.get(pipeline.pass).ok_or_else(|| {
                PlanError(format!(
                    "pipeline {i} ({name}) names pass {}",
                    pipeline.pass
                ))
            })?;
            ensure!(
                pipeline.subpass < pass.kind.subpass_count(),
                "pipeline {name}: subpass {} of a pass with {}",
                pipeline.subpass,
                pass.kind.subpass_count()
            );
            let has_color = pass.has_color(pipeline.subpass);
            ensure!(
                has_color == (pipeline.program != Program::DepthOnly),
                "pipeline {name}: a depth-only program where there is a color attachment, or \
                 a fragment shader where there is none"
            );
            let slices = self.needs().depth_subresources;
            match pipeline.program {
                Program::DepthMipsPost => ensure!(
                    pass.target == Target::Post && slices.levels >= 3,
                    "pipeline {name}: the mip chain's post program samples levels 1 and 2 in a \
                     post pass"
                ),
                Program::DepthLayersPost => ensure!(
                    pass.target == Target::Post && slices.layers >= 2,
                    "pipeline {name}: the layers' post program samples layers 0 and 1 in a post \
                     pass"
                ),
                Program::DepthPostMs => ensure!(
                    pass.target == Target::Post
                        && self.needs().multisample.is_some_and(|m| m.sampled_depth),
                    "pipeline {name}: the multisampled depth's post program samples the depth \
                     a multisampled pass kept, in a post pass"
                ),
                _ => {}
            }
            // The input-attachment program the pass maps the depth to, where the pipeline's
            // subpass reads it.
            let input_program = pass
                .kind
                .depth_input_program()
                .filter(|_| pass.reads_depth_input(pipeline.subpass));
            // Its buffer holds two views' matrices, which only a multiview pass renders.
            ensure!(
                (pipeline.program == Program::Multiview) == (pass.view_mask != 0),
                "pipeline {name}: the multiview program draws in the multiview passes, and they \
                 draw with it alone"
            );
            ensure!(
                pass.view_mask == 0 || (pass.view_mask < 4 && !pipeline.libraries),
                "pipeline {name}: multiview passes render at most two views (the views' buffer \
                 holds two), with pipelines made in one call"
            );
            ensure!(
                match input_program {
                    Some(program) => pipeline.program == program,
                    None => !pipeline.program.reads_depth_input(),
                },
                "pipeline {name}: a depth-input program is for subpass 1 of a pass that reads \
                 the depth as an input attachment (the decorated one where the depth is mapped \
                 to index 0, the undecorated one where a rendering keeps the default mapping), \
                 and that subpass draws with it alone"
            );
            if pass.reads_depth_input(pipeline.subpass) {
                ensure!(
                    pass.target == Target::Main && !pipeline.depth_write,
                    "pipeline {name}: the depth is read-only while it is an input attachment"
                );
            }
            if !pass.has_depth(pipeline.subpass) {
                ensure!(
                    pipeline.depth_test == DepthTest::Off
                        && pipeline.stencil.is_none()
                        && pipeline.bounds == Bounds::Off
                        && pipeline.bias == Bias::Off,
                    "pipeline {name}: depth or stencil state in a subpass without a depth \
                     attachment"
                );
            }
            ensure!(
                pipeline.color_write || !pipeline.program.receives_shadow(),
                "pipeline {name}: a shadow receiver without color writes"
            );
            ensure!(
                pipeline.program != Program::DepthOnly || !pipeline.color_write,
                "pipeline {name}: depth-only with color writes"
            );
            ensure!(
                !pipeline.program.receives_shadow() || pass.target == Target::Main,
                "pipeline {name}: a shadow receiver drawing into the shadow map"
            );
            // The renderer makes one set of buffers, with the camera's matrices.
            ensure!(
                !pipeline.program.is_buffer_delivery()
                    || (pass.target == Target::Main
                        && self.buffer_program() == Some(pipeline.program)),
                "pipeline {name}: a buffer delivery drawing into the shadow map, or two \
                 buffer deliveries in one plan"
            );
            ensure!(
                !pipeline.libraries
                    || !pass.kind.is_dynamic_rendering()
                    || pass.kind == PassKind::DynamicRendering,
                "pipeline {name}: library pipelines are built for render passes and plain \
                 dynamic renderings"
            );
            ensure!(
                pass.target == Target::Main || pipeline.stencil.is_none(),
                "pipeline {name}: stencil test on the shadow map (it has no stencil)"
            );
            if let Viewport::Static {
                min_depth,
                max_depth,
            } = pipeline.viewport
            {
                // Outside [0, 1] is allowed: the plan then needs (and the device gets)
                // VK_EXT_depth_range_unrestricted (`Plan::needs`).
                ensure!(
                    min_depth.is_finite() && max_depth.is_finite(),
                    "pipeline {name}: viewport depth range not finite"
                );
            }
            if let Bounds::Static { min, max } = pipeline.bounds {
                ensure!(
                    0.0 <= min && min <= max && max <= 1.0,
                    "pipeline {name}: bad depth bounds"
                );
            }
        }
        for (n, pass) in self.passes.iter().enumerate() {
            let Some(multisample) = pass.multisample else {
                continue;
            };
            let samples = multisample.samples;
            ensure!(
                samples.is_power_of_two() && (2..=64).contains(&samples),
                "pass {n}: {samples} samples (2, 4, 8, 16, 32 or 64)"
            );
            ensure!(
                pass.target == Target::Main,
                "pass {n}: only the main target is multisampled"
            );
            ensure!(
                pass.kind.subpass_count() == 1,
                "pass {n}: multisampled passes have one subpass"
            );
            // The multisampled attachments are transient: nothing of them survives a pass.
            ensure!(
                matches!(pass.depth, DepthLoad::Clear(_)) && !pass.load_color,
                "pass {n}: a multisampled pass clears its attachments (they are transient)"
            );
            ensure!(
                !multisample.sampled_depth || pass.kind == PassKind::RenderPass,
                "pass {n}: a multisampled depth kept for shaders is rendered in a render pass"
            );
            ensure!(
                self.passes
                    .iter()
                    .filter_map(|p| p.multisample)
                    .all(|other| other == multisample),
                "pass {n}: multisampled passes differ in samples or resolve (they share one \
                 set of attachments)"
            );
        }
        let shadow_receivers = self.pipelines.iter().any(|p| p.program.receives_shadow());
        let shadow_passes = self.passes.iter().any(|p| p.target == Target::Shadow);
        ensure!(
            !shadow_passes || has_light,
            "a shadow pass in a scene without a light"
        );

        // One input-attachment descriptor, written for one layout: the render pass's
        // read-only one, or the local-read rendering's.
        ensure!(
            self.passes
                .iter()
                .filter(|p| p.kind.reads_depth_input())
                .map(|p| p.kind.reads_locally())
                .collect::<std::collections::BTreeSet<_>>()
                .len()
                <= 1,
            "the depth is read as an input attachment both in a render pass and in a dynamic \
             rendering (one descriptor, written for one layout)"
        );
        for (n, pass) in self.passes.iter().enumerate() {
            ensure!(
                !pass.kind.reads_depth_input()
                    || (pass.target == Target::Main && pass.multisample.is_none()),
                "pass {n}: the depth is read as an input attachment of the main target's \
                 single-sample pass"
            );
            // The renderer attaches 2D-array views of the main images' layers, single-sample.
            ensure!(
                pass.view_mask == 0
                    || (pass.target == Target::Main
                        && pass.multisample.is_none()
                        && matches!(pass.kind, PassKind::RenderPass | PassKind::DynamicRendering)),
                "pass {n}: a multiview pass renders the main target in one single-sample subpass"
            );
            if let Target::DepthSlice { .. } = pass.target {
                ensure!(
                    pass.kind == PassKind::RenderPass && pass.multisample.is_none(),
                    "pass {n}: a depth slice is rendered in a one-subpass single-sample render \
                     pass"
                );
            }
            if matches!(pass.target, Target::SoftParticles | Target::Post) {
                ensure!(
                    pass.kind == PassKind::RenderPass
                        && pass.depth == DepthLoad::Load
                        && pass.load_color,
                    "pass {n}: a pass reading the main depth is a one-subpass render pass that \
                     loads it and the color"
                );
            }
        }
        let mut state = CheckState::default();
        let mut shadow_drawn = false;
        // Where each mip level of the main depth image is between passes: in its attachment
        // layout, or sampled.
        let levels = self.needs().depth_subresources.levels as usize;
        let mut depth_layout = vec![DepthLayout::Attachment; levels];
        // Where the multisampled depth a multisampled pass keeps is between passes.
        let mut multisampled_layout = DepthLayout::Attachment;
        let post_samples_main = self.post_samples_main_depth();
        let post_samples_multisampled = self
            .pipelines
            .iter()
            .any(|p| p.program == Program::DepthPostMs);
        let mut used_passes = vec![false; self.passes.len()];
        let mut used_pipelines = vec![false; self.pipelines.len()];
        for (index, step) in self.steps.iter().enumerate() {
            let at = |message: String| PlanError(format!("step {index} ({step:?}): {message}"));
            match step {
                Step::ClearDepthImage { depth } => {
                    ensure!(
                        state.pass.is_none(),
                        "step {index}: image clear inside a pass"
                    );
                    ensure!(depth.is_finite(), "step {index}: depth not finite");
                    ensure!(
                        depth_layout[0] == DepthLayout::Attachment,
                        "step {index}: the main depth image is not in its attachment layout"
                    );
                }
                Step::BindDepthTiles(_) => {
                    ensure!(
                        state.pass.is_none(),
                        "step {index}: a compute bind inside a pass"
                    );
                }
                Step::BuildDepthTiles => {
                    ensure!(
                        state.pass.is_none(),
                        "step {index}: a dispatch inside a pass"
                    );
                    ensure!(
                        depth_layout[0] == DepthLayout::Sampled,
                        "step {index}: the main depth image is not sampled"
                    );
                }
                Step::MainDepthLayout { from, to } => {
                    ensure!(
                        state.pass.is_none(),
                        "step {index}: a depth layout barrier inside a pass"
                    );
                    ensure!(
                        depth_layout.iter().all(|layout| layout == from)
                            && from != to
                            && *from != DepthLayout::Undefined
                            && *to != DepthLayout::Undefined,
                        "step {index}: the main depth image's levels are {depth_layout:?}"
                    );
                    depth_layout.fill(*to);
                }
                Step::MultisampledDepthLayout { from, to } => {
                    ensure!(
                        state.pass.is_none(),
                        "step {index}: a depth layout barrier inside a pass"
                    );
                    ensure!(
                        self.needs().multisample.is_some_and(|m| m.sampled_depth),
                        "step {index}: no multisampled pass keeps its depth"
                    );
                    ensure!(
                        multisampled_layout == *from
                            && from != to
                            && *from != DepthLayout::ReadOnly
                            && *to != DepthLayout::ReadOnly,
                        "step {index}: the multisampled depth image is {multisampled_layout:?}"
                    );
                    multisampled_layout = *to;
                }
                Step::DepthLevelLayout { level, from, to } => {
                    ensure!(
                        state.pass.is_none(),
                        "step {index}: a depth layout barrier inside a pass"
                    );
                    let current = depth_layout[*level as usize];
                    // From UNDEFINED: whatever it holds is discarded.
                    ensure!(
                        (current == *from || *from == DepthLayout::Undefined)
                            && from != to
                            && *to != DepthLayout::Undefined,
                        "step {index}: level {level} of the main depth image is {current:?}"
                    );
                    depth_layout[*level as usize] = *to;
                }
                Step::BlitDepthLevel { level } => {
                    ensure!(state.pass.is_none(), "step {index}: a blit inside a pass");
                    let level = *level as usize;
                    ensure!(
                        level > 0
                            && depth_layout[level - 1] == DepthLayout::TransferSrc
                            && depth_layout[level] == DepthLayout::TransferDst,
                        "step {index}: blits a level from the one below it, in TRANSFER_SRC \
                         and TRANSFER_DST (the levels are {depth_layout:?})"
                    );
                }
                Step::BeginPass(n) => {
                    ensure!(state.pass.is_none(), "step {index}: nested pass");
                    let pass = self
                        .passes
                        .get(*n)
                        .ok_or_else(|| at(format!("no pass {n}")))?;
                    if pass.target == Target::Main && shadow_receivers {
                        ensure!(
                            shadow_drawn,
                            "step {index}: the main pass samples a shadow map not drawn yet"
                        );
                    }
                    ensure!(
                        pass.target != Target::Shadow || !pass.load_color,
                        "step {index}: the shadow map has no color to load"
                    );
                    // The levels the pass attaches must be attachments, those it samples sampled.
                    let (attached, sampled): (Option<u32>, Vec<u32>) = match pass.target {
                        Target::Shadow => (None, Vec::new()),
                        Target::Post if !post_samples_main => (None, Vec::new()),
                        Target::Post => (None, (0..levels as u32).collect()),
                        Target::Main | Target::SoftParticles => (Some(0), Vec::new()),
                        Target::DepthSlice { level, .. } => (Some(level), Vec::new()),
                    };
                    ensure!(
                        attached.is_none_or(|level| {
                            depth_layout[level as usize] == DepthLayout::Attachment
                        }) && sampled
                            .iter()
                            .all(|&level| depth_layout[level as usize] == DepthLayout::Sampled),
                        "step {index}: the main depth image's levels are {depth_layout:?} at the \
                         pass"
                    );
                    // A post pass reads the kept multisampled depth sampled; a multisampled
                    // pass draws into it in its attachment layout.
                    let multisampled_expected = match pass.target {
                        Target::Post if post_samples_multisampled => Some(DepthLayout::Sampled),
                        _ if pass.multisample.is_some() => Some(DepthLayout::Attachment),
                        _ => None,
                    };
                    ensure!(
                        multisampled_expected.is_none_or(|l| l == multisampled_layout),
                        "step {index}: the multisampled depth image is {multisampled_layout:?} \
                         at the pass"
                    );
                    used_passes[*n] = true;
                    state.pass = Some((*n, 0));
                    state.secondary_subpass = None;
                }
                Step::NextSubpass => {
                    let (n, subpass) = state.pass.ok_or_else(|| at("outside a pass".into()))?;
                    ensure!(
                        subpass + 1 < self.passes[n].kind.subpass_count(),
                        "step {index}: no next subpass"
                    );
                    // A local-read rendering's "next subpass" is its by-region barrier.
                    ensure!(
                        self.passes[n].kind != PassKind::DynamicRendering,
                        "step {index}: dynamic rendering has no subpasses"
                    );
                    state.pass = Some((n, subpass + 1));
                    state.secondary_subpass = None;
                }
                Step::EndPass => {
                    let (n, subpass) = state.pass.ok_or_else(|| at("outside a pass".into()))?;
                    ensure!(
                        subpass + 1 == self.passes[n].kind.subpass_count(),
                        "step {index}: the pass ends before its last subpass"
                    );
                    shadow_drawn |= self.passes[n].target == Target::Shadow;
                    if self.passes[n].target == Target::SoftParticles {
                        depth_layout[0] = DepthLayout::ReadOnly;
                    }
                    state.pass = None;
                }
                Step::ExecuteSecondaries(lists, _) => {
                    let (n, subpass) = state.pass.ok_or_else(|| at("outside a pass".into()))?;
                    // A plain single-sample rendering continues in secondaries too (its formats
                    // inherited); its local-read and suspended kinds do not here.
                    ensure!(
                        !self.passes[n].kind.is_dynamic_rendering()
                            || (self.passes[n].kind == PassKind::DynamicRendering
                                && self.passes[n].multisample.is_none()),
                        "step {index}: secondaries are recorded inside render passes and plain \
                         single-sample renderings"
                    );
                    ensure!(
                        state.secondary_subpass != Some(false),
                        "step {index}: inline commands and secondaries in one subpass"
                    );
                    ensure!(!lists.is_empty(), "step {index}: no secondary");
                    state.secondary_subpass = Some(true);
                    for list in lists {
                        // Secondaries inherit nothing but the pass: their own binds and state.
                        let mut inner = CheckState {
                            pass: Some((n, subpass)),
                            ..CheckState::default()
                        };
                        for step in list {
                            ensure!(
                                !matches!(
                                    step,
                                    Step::BeginPass(_)
                                        | Step::EndPass
                                        | Step::NextSubpass
                                        | Step::ClearDepthImage { .. }
                                        | Step::MainDepthLayout { .. }
                                        | Step::DepthLevelLayout { .. }
                                        | Step::BlitDepthLevel { .. }
                                        | Step::MultisampledDepthLayout { .. }
                                        | Step::BuildDepthTiles
                                        | Step::BindDepthTiles(_)
                                        | Step::ExecuteSecondaries(..)
                                ),
                                "step {index}: {step:?} inside a secondary"
                            );
                            self.check_inline(
                                step,
                                &mut inner,
                                objects,
                                &mut used_pipelines,
                                index,
                            )?;
                        }
                    }
                    // The primary's bound pipeline and dynamic state are undefined afterwards.
                    state.pipeline = None;
                }
                _ => {
                    ensure!(
                        state.secondary_subpass != Some(true),
                        "step {index}: inline commands and secondaries in one subpass"
                    );
                    state.secondary_subpass = Some(false);
                    self.check_inline(step, &mut state, objects, &mut used_pipelines, index)?;
                }
            }
        }
        ensure!(state.pass.is_none(), "the last pass is not ended");
        ensure!(
            depth_layout.iter().all(|&l| l == DepthLayout::Attachment),
            "the main depth image is not left in its attachment layout (the read-back's)"
        );
        ensure!(
            multisampled_layout == DepthLayout::Attachment,
            "the multisampled depth image is not left in its attachment layout"
        );
        if let Some(n) = used_passes.iter().position(|used| !used) {
            return Err(PlanError(format!("pass {n} is never begun")));
        }
        if let Some(n) = used_pipelines.iter().position(|used| !used) {
            return Err(PlanError(format!(
                "pipeline {n} ({}) is never bound",
                self.pipelines[n].name
            )));
        }
        Ok(())
    }

    /// Checks one step recorded inside a pass (in the primary or a secondary).
    fn check_inline(
        &self,
        step: &Step,
        state: &mut CheckState,
        objects: usize,
        used_pipelines: &mut [bool],
        index: usize,
    ) -> Result<(), PlanError> {
        let at = |message: &str| PlanError(format!("step {index} ({step:?}): {message}"));
        let (pass_index, subpass) = state.pass.ok_or_else(|| at("outside a pass"))?;
        let pass = &self.passes[pass_index];
        let bound = |state: &CheckState| -> Result<&PipelineSpec, PlanError> {
            state
                .pipeline
                .map(|n| &self.pipelines[n])
                .ok_or_else(|| at("no pipeline bound"))
        };
        match step {
            Step::Bind(n) => {
                let pipeline = self
                    .pipelines
                    .get(*n)
                    .ok_or_else(|| at("no such pipeline"))?;
                ensure!(
                    pass.compatible(&self.passes[pipeline.pass]) && pipeline.subpass == subpass,
                    "step {index}: pipeline {} is made for another pass or subpass",
                    pipeline.name
                );
                used_pipelines[*n] = true;
                state.pipeline = Some(*n);
                state.set = [false; 4];
                let size = pipeline.program.push_constant_size();
                if state.pushed.1 != size {
                    state.pushed = (0, size);
                }
            }
            Step::Push {
                object,
                offset,
                size,
            } => {
                ensure!(*object < objects, "step {index}: no object {object}");
                let declared = bound(state)?.program.push_constant_size();
                ensure!(
                    offset % 4 == 0 && size % 4 == 0 && *size > 0 && offset + size <= declared,
                    "step {index}: push range {offset}+{size} is not 4-aligned inside the \
                     program's {declared} bytes"
                );
                for word in offset / 4..(offset + size) / 4 {
                    state.pushed.0 |= 1 << word;
                }
            }
            Step::Draw(n) | Step::DrawPushed(n) => {
                ensure!(*n < objects, "step {index}: no object {n}");
                let pipeline = bound(state)?;
                let size = pipeline.program.push_constant_size();
                let all = if size == 128 {
                    u32::MAX
                } else {
                    (1u32 << (size / 4)) - 1
                };
                if matches!(step, Step::Draw(_)) {
                    state.pushed.0 = all;
                }
                ensure!(
                    state.pushed.0 & all == all,
                    "step {index}: drawn before all {size} bytes of push constants were pushed"
                );
                let needed = [
                    pipeline.depth_test == DepthTest::Dynamic,
                    pipeline.bias == Bias::Dynamic,
                    pipeline.bounds == Bounds::Dynamic,
                    pipeline.viewport == Viewport::Dynamic,
                ];
                for (what, (needed, set)) in
                    ["compare op", "depth bias", "depth bounds", "viewport"]
                        .iter()
                        .zip(needed.iter().zip(state.set))
                {
                    ensure!(
                        !needed || set,
                        "step {index}: dynamic {what} of {} not set before the draw",
                        pipeline.name
                    );
                }
            }
            Step::SetDepthCompareOp(_) => {
                ensure!(
                    bound(state)?.depth_test == DepthTest::Dynamic,
                    "step {index}: the compare op is not dynamic"
                );
                state.set[0] = true;
            }
            Step::SetDepthBias(_) => {
                ensure!(
                    bound(state)?.bias == Bias::Dynamic,
                    "step {index}: the depth bias is not dynamic"
                );
                state.set[1] = true;
            }
            Step::SetDepthBounds { min, max } => {
                ensure!(
                    bound(state)?.bounds == Bounds::Dynamic,
                    "step {index}: the depth bounds are not dynamic"
                );
                ensure!(
                    0.0 <= *min && min <= max && *max <= 1.0,
                    "step {index}: bad depth bounds"
                );
                state.set[2] = true;
            }
            Step::SetViewport {
                min_depth,
                max_depth,
            } => {
                ensure!(
                    bound(state)?.viewport == Viewport::Dynamic,
                    "step {index}: the viewport is not dynamic"
                );
                ensure!(
                    min_depth.is_finite() && max_depth.is_finite(),
                    "step {index}: viewport depth range not finite"
                );
                state.set[3] = true;
            }
            Step::ClearDepthRect { rect, depth } => {
                ensure!(
                    pass.target == Target::Main,
                    "step {index}: rectangle clears are for the main target"
                );
                let [x0, y0, x1, y1] = *rect;
                ensure!(
                    0.0 <= x0 && x0 < x1 && x1 <= 1.0 && 0.0 <= y0 && y0 < y1 && y1 <= 1.0,
                    "step {index}: bad rectangle"
                );
                ensure!(
                    (0.0..=1.0).contains(depth),
                    "step {index}: depth outside [0, 1]"
                );
            }
            Step::ClearDepthImage { .. }
            | Step::MainDepthLayout { .. }
            | Step::DepthLevelLayout { .. }
            | Step::BlitDepthLevel { .. }
            | Step::MultisampledDepthLayout { .. }
            | Step::BuildDepthTiles
            | Step::BindDepthTiles(_)
            | Step::BeginPass(_)
            | Step::NextSubpass
            | Step::EndPass
            | Step::ExecuteSecondaries(..) => unreachable!("handled by Plan::check"),
        }
        Ok(())
    }
}
