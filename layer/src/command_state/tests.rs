//! The state machine's tests: what each command sends down, through a recording sink.

use std::sync::Arc;

use ash::vk::Handle;

use super::*;
use crate::objects::PositionShader;
use crate::shader::derived_range::MatrixSource;

#[derive(Clone, Debug, Default, PartialEq)]
struct Recorded {
    viewports: Vec<(u32, Vec<(f32, f32)>)>,
    with_count: Vec<Vec<(f32, f32)>>,
    compare_ops: Vec<vk::CompareOp>,
    biases: Vec<DepthBias>,
    bounds: Vec<(f32, f32)>,
    pushes: Vec<(u32, usize)>,
    /// The layout and bytes of each push.
    pushed: Vec<(vk::PipelineLayout, Vec<u8>)>,
    clip_conventions: Vec<bool>,
    clamp_ranges: Vec<Option<(f32, f32)>>,
    binds: Vec<vk::Pipeline>,
    shader_binds: Vec<vk::ShaderEXT>,
    /// Binds of vertex, tessellation evaluation and geometry shader objects.
    position_shader_binds: Vec<(vk::ShaderStageFlags, vk::ShaderEXT)>,
}

impl PushSink for Recorded {
    fn push_constants(
        &mut self,
        layout: vk::PipelineLayout,
        _: vk::ShaderStageFlags,
        offset: u32,
        bytes: &[u8],
    ) {
        self.pushes.push((offset, bytes.len()));
        self.pushed.push((layout, bytes.to_vec()));
    }
}

impl StateSink for Recorded {
    fn set_viewports(&mut self, first: u32, viewports: &[vk::Viewport]) {
        let depths = viewports
            .iter()
            .map(|v| (v.min_depth, v.max_depth))
            .collect();
        self.viewports.push((first, depths));
    }
    fn set_viewports_with_count(&mut self, viewports: &[vk::Viewport]) {
        let depths = viewports
            .iter()
            .map(|v| (v.min_depth, v.max_depth))
            .collect();
        self.with_count.push(depths);
    }
    fn set_compare_op(&mut self, op: vk::CompareOp) {
        self.compare_ops.push(op);
    }
    fn set_bias(&mut self, bias: DepthBias) {
        self.biases.push(bias);
    }
    fn set_clip_negative_one_to_one(&mut self, negative_one_to_one: bool) {
        self.clip_conventions.push(negative_one_to_one);
    }

    fn set_bounds(&mut self, min: f32, max: f32) {
        self.bounds.push((min, max));
    }
    fn set_clamp_range(&mut self, range: Option<(f32, f32)>) {
        self.clamp_ranges.push(range);
    }
    fn bind_pipeline(&mut self, pipeline: vk::Pipeline) {
        self.binds.push(pipeline);
    }
    fn bind_shader(&mut self, stage: vk::ShaderStageFlags, shader: vk::ShaderEXT) {
        if stage == vk::ShaderStageFlags::FRAGMENT {
            self.shader_binds.push(shader);
        } else {
            self.position_shader_binds.push((stage, shader));
        }
    }
}

fn viewport(min_depth: f32, max_depth: f32) -> vk::Viewport {
    vk::Viewport {
        width: 256.0,
        height: 256.0,
        min_depth,
        max_depth,
        ..Default::default()
    }
}

/// A command buffer of a flip-mode device, begun with `target`.
fn begun(target: Target) -> CommandState {
    let mut state = CommandState::default();
    state.begin(target, Reversal::Complementary, Cameras::default());
    state
}

/// A pipeline whose viewport and compare op were static and made dynamic by revz.
fn static_pipeline() -> Arc<PipelineDepth> {
    Arc::new(PipelineDepth {
        app_dynamic: States::NONE,
        injected: States::VIEWPORT | States::COMPARE_OP | States::BIAS,
        viewports: vec![viewport(0.0, 1.0)],
        compare_op: vk::CompareOp::LESS,
        bias: DepthBias {
            constant: -1.0,
            clamp: 0.0,
            slope: -2.0,
            representation: None,
        },
        bounds: (0.0, 1.0),
        clamp_range: (0.0, 1.0),
        static_clamp: false,
        depth_clip: DepthClip::Implied,
        unreversed_fragment: false,
        handle: vk::Pipeline::null(),
        reversed_variant: None,
        promotable: false,
        promoted_variant: None,
        promoted_reversed_variant: None,
        input_variant: None,
        promoted_input_variant: None,
        projection: None,
        position_store: None,
        derived_range: None,
        baked: false,
        layout: vk::PipelineLayout::null(),
        subsets: vk::GraphicsPipelineLibraryFlagsEXT::empty(),
        module_identifiers: false,
    })
}

#[test]
fn a_compare_op_variant_is_bound_for_reversed_draws_and_the_original_for_native_ones() {
    let original = vk::Pipeline::from_raw(10);
    let variant = vk::Pipeline::from_raw(11);
    let pipeline = Arc::new(PipelineDepth {
        injected: States::VIEWPORT,
        viewports: vec![viewport(0.0, 1.0)],
        compare_op: vk::CompareOp::LESS,
        handle: original,
        reversed_variant: Some(variant),
        ..PipelineDepth::default()
    });
    let mut state = begun(Target::Reversed);
    state.bind_pipeline(Some(Arc::clone(&pipeline)));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    state.before_draw(&mut sink);
    assert_eq!(
        sink.binds,
        vec![variant],
        "bound once, for the reversed draws"
    );
    assert!(
        sink.compare_ops.is_empty(),
        "the variant holds the compare op"
    );
    assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.0)])]);

    // A native pass: the application's pipeline comes back.
    state.set_target(Target::Native);
    state.before_draw(&mut sink);
    assert_eq!(sink.binds, vec![variant, original]);

    // The application binds again (its own pipeline goes down): reversed draws need the
    // variant bound again; native ones need nothing.
    state.bind_pipeline(Some(Arc::clone(&pipeline)));
    state.before_draw(&mut sink);
    assert_eq!(sink.binds, vec![variant, original]);
    state.set_target(Target::Reversed);
    state.bind_pipeline(Some(pipeline));
    state.before_draw(&mut sink);
    assert_eq!(sink.binds, vec![variant, original, variant]);
}

/// A static pipeline (10) with a reversed variant (11).
fn with_reversed_variant() -> (vk::Pipeline, vk::Pipeline, Arc<PipelineDepth>) {
    let original = vk::Pipeline::from_raw(10);
    let variant = vk::Pipeline::from_raw(11);
    let pipeline = Arc::new(PipelineDepth {
        handle: original,
        reversed_variant: Some(variant),
        ..(*static_pipeline()).clone()
    });
    (original, variant, pipeline)
}

#[test]
fn state_settles_inside_passes_only_and_a_variant_goes_down_in_the_binds_place() {
    let (original, variant, pipeline) = with_reversed_variant();
    // A primary, outside any pass: the bind goes down as the application's, and nothing
    // else is sent (no draw can follow before a begin).
    let mut state = CommandState::default();
    state.begin(Target::None, Reversal::Complementary, Cameras::default());
    state.bind_pipeline(Some(Arc::clone(&pipeline)));
    assert_eq!(state.pipeline_to_bind(original), original);
    state.set_compare_op(vk::CompareOp::LESS);
    let mut sink = Recorded::default();
    assert!(state.settle(&mut sink).is_none());
    assert_eq!(sink, Recorded::default(), "nothing outside a pass");
    // The pass begins into a reversed attachment: everything the next draw needs goes
    // down once, as the begin settles, and a draw then sends nothing.
    state.set_target(Target::Reversed);
    state.settle(&mut sink);
    assert_eq!(sink.binds, vec![variant]);
    assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.0)])]);
    assert_eq!(sink.biases.len(), 1);
    let sent = sink.clone();
    state.settle(&mut sink);
    state.before_draw(&mut sink);
    assert_eq!(sink, sent, "nothing more for the draw");
    // A bind inside the pass: the variant is what goes down, and nothing after it.
    state.bind_pipeline(Some(Arc::clone(&pipeline)));
    assert_eq!(state.pipeline_to_bind(original), variant);
    state.settle(&mut sink);
    assert_eq!(sink.binds, vec![variant], "no second bind");
    // Inside a subpass of secondaries nothing may be recorded: it waits.
    state.set_secondary_contents(true);
    state.set_target(Target::Native);
    state.settle(&mut sink);
    assert_eq!(sink.binds, vec![variant]);
    state.set_secondary_contents(false);
    state.settle(&mut sink);
    assert_eq!(sink.binds, vec![variant, original]);
    // The pass ends: nothing goes down until the next begin.
    state.leave_pass();
    state.set_compare_op(vk::CompareOp::GREATER);
    let sent = sink.clone();
    state.settle(&mut sink);
    assert_eq!(sink, sent);
}

#[test]
fn a_push_revz_cannot_follow_keeps_the_variant_it_bound_in_mind() {
    let (original, variant, pipeline) = with_reversed_variant();
    let mut state = begun(Target::Reversed);
    state.bind_pipeline(Some(pipeline));
    assert_eq!(state.pipeline_to_bind(original), variant);
    let mut sink = Recorded::default();
    state.settle(&mut sink);
    // `vkCmdPushConstants2` with its layout in pNext: the pushes are unknown, the bound
    // pipeline is not. A later native target must bind the application's pipeline back
    // (forgetting the variant would leave it bound into a native attachment).
    state.forget_push_constants();
    state.settle(&mut sink);
    assert!(sink.binds.is_empty(), "{:?}", sink.binds);
    state.set_target(Target::Native);
    state.settle(&mut sink);
    assert_eq!(sink.binds, vec![original]);
}

#[test]
fn a_fragment_shader_objects_variant_is_bound_for_reversed_draws_and_the_app_shader_back() {
    let shader = vk::ShaderEXT::from_raw(20);
    let variant = vk::ShaderEXT::from_raw(21);
    let fragment = Some((shader, Some(FragmentShader::Reversed(variant))));
    let mut state = begun(Target::Reversed);
    state.bind_shaders(fragment, Default::default());
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    state.before_draw(&mut sink);
    assert_eq!(
        sink.shader_binds,
        [variant],
        "bound once, for reversed draws"
    );
    assert!(sink.binds.is_empty());

    // Binding other stages leaves the variant in place of the application's shader.
    state.bind_shaders(None, Default::default());
    state.before_draw(&mut sink);
    assert_eq!(sink.shader_binds, [variant]);

    // A native pass: the application's shader comes back, once.
    state.set_target(Target::Native);
    state.before_draw(&mut sink);
    state.before_draw(&mut sink);
    assert_eq!(sink.shader_binds, [variant, shader]);

    // The application binds its shader again (it goes down): native draws need nothing,
    // reversed ones the variant again.
    state.bind_shaders(fragment, Default::default());
    state.before_draw(&mut sink);
    assert_eq!(sink.shader_binds, [variant, shader]);
    state.set_target(Target::Reversed);
    state.before_draw(&mut sink);
    assert_eq!(sink.shader_binds, [variant, shader, variant]);

    // Secondaries leave the bindings undefined: the variant is bound again.
    state.invalidate();
    state.before_draw(&mut sink);
    assert_eq!(sink.shader_binds, [variant, shader, variant, variant]);
}

#[test]
fn a_baked_vertex_shader_object_takes_the_precise_path_where_it_is_the_last_stage() {
    let vertex = vk::ShaderEXT::from_raw(40);
    let variant = vk::ShaderEXT::from_raw(41);
    let baked = Some((
        vertex,
        Some(PositionShader::Baked {
            variant,
            projects_input: false,
        }),
    ));
    let stage = vk::ShaderStageFlags::VERTEX;
    for target in [RewriteTarget::Complementary, RewriteTarget::Infinite] {
        let mut state = precise(target);
        let reversal = state.reversal();
        state.begin(Target::Reversed, reversal, Default::default());
        state.bind_shaders(None, [baked.clone(), None, None, None]);
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        assert_eq!(sink.position_shader_binds, [(stage, variant)], "once");
        assert!(sink.pushed.is_empty(), "nothing pushed");
        // A [-1, 1] clip convention: the flip path, the application's shader back.
        state.set_clip_negative_one_to_one(true);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip);
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, vertex)));
        state.set_clip_negative_one_to_one(false);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, variant)));
        // A geometry shader without a variant is rasterized: the flip path; unbound again
        // (null), the vertex stage's variant comes back.
        let geometry = vk::ShaderEXT::from_raw(42);
        state.bind_shaders(None, [None, None, Some((geometry, None)), None]);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip);
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, vertex)));
        state.bind_shaders(
            None,
            [None, None, Some((vk::ShaderEXT::null(), None)), None],
        );
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        // A geometry shader that passes the positions through: the vertex stage's variant
        // stores them, and stays bound (nothing sent); the geometry shader is left alone.
        let sent = sink.position_shader_binds.len();
        state.bind_shaders(
            None,
            [
                None,
                None,
                Some((geometry, Some(PositionShader::PassesThrough))),
                None,
            ],
        );
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        assert_eq!(sink.position_shader_binds.len(), sent);
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, variant)));
        // The application binds its vertex shader again: the variant goes down in its place.
        state.bind_shaders(None, [baked.clone(), None, None, None]);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, variant)));
        assert_eq!(sink.position_shader_binds.len(), sent + 1);
        state.bind_shaders(
            None,
            [None, None, Some((vk::ShaderEXT::null(), None)), None],
        );
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        // A mesh shader without a variant bound: it is rasterized, the flip path; unbound
        // again, the vertex stage's variant comes back.
        let mesh = vk::ShaderEXT::from_raw(43);
        state.bind_shaders(None, [None, None, None, Some((mesh, None))]);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip);
        state.bind_shaders(
            None,
            [None, None, None, Some((vk::ShaderEXT::null(), None))],
        );
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        // A mesh shader with a variant (the vertex stage left bound: the mesh stage is the
        // one rasterized): its variant, bound in its place.
        let mesh_variant = vk::ShaderEXT::from_raw(44);
        state.bind_shaders(
            None,
            [
                None,
                None,
                None,
                Some((
                    mesh,
                    Some(PositionShader::Baked {
                        variant: mesh_variant,
                        projects_input: false,
                    }),
                )),
            ],
        );
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        assert_eq!(
            sink.position_shader_binds.last(),
            Some(&(vk::ShaderStageFlags::MESH_EXT, mesh_variant))
        );
        state.bind_shaders(
            None,
            [None, None, None, Some((vk::ShaderEXT::null(), None))],
        );
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        // A pipeline bound replaces the shader objects: no shader bound back.
        let sent = sink.position_shader_binds.len();
        state.bind_pipeline(Some(static_pipeline()));
        state.before_draw(&mut sink);
        assert_eq!(sink.position_shader_binds.len(), sent);
        assert_eq!(state.path(), DrawPath::Flip);
    }
    // Infinite mode: a depth clamp turned on (always dynamic with shader objects) sends the
    // draws to the flip path.
    let mut state = precise(RewriteTarget::Infinite);
    let reversal = state.reversal();
    state.begin(Target::Reversed, reversal, Default::default());
    state.bind_shaders(None, [baked, None, None, None]);
    let mut sink = Recorded::default();
    state.set_depth_clamp(true);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    assert!(sink.position_shader_binds.is_empty());
    state.set_depth_clamp(false);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert_eq!(sink.position_shader_binds, [(stage, variant)]);
}

#[test]
fn unbinding_the_fragment_shader_or_binding_a_pipeline_forgets_its_variant() {
    let shader = vk::ShaderEXT::from_raw(30);
    let variant = vk::ShaderEXT::from_raw(31);
    let fragment = Some((shader, Some(FragmentShader::Reversed(variant))));
    let mut state = begun(Target::Reversed);
    let mut sink = Recorded::default();

    // Unbound (null): nothing to swap.
    state.bind_shaders(fragment, Default::default());
    state.bind_shaders(Some((vk::ShaderEXT::null(), None)), Default::default());
    state.before_draw(&mut sink);
    assert!(sink.shader_binds.is_empty());

    // A pipeline bound after the variant unbinds it: native draws bind nothing back.
    state.bind_shaders(fragment, Default::default());
    state.before_draw(&mut sink);
    assert_eq!(sink.shader_binds, [variant]);
    state.bind_pipeline(Some(static_pipeline()));
    state.before_draw(&mut sink);
    state.set_target(Target::Native);
    state.before_draw(&mut sink);
    assert_eq!(sink.shader_binds, [variant]);

    // Shaders without a variant (plain, or marked unreversed) are never swapped.
    for depth in [None, Some(FragmentShader::Unreversed)] {
        state.set_target(Target::Reversed);
        state.bind_shaders(Some((shader, depth)), Default::default());
        state.before_draw(&mut sink);
        state.set_target(Target::Native);
        state.before_draw(&mut sink);
    }
    assert_eq!(sink.shader_binds, [variant]);
}

#[test]
fn static_state_is_emitted_flipped_for_a_reversed_target_once() {
    let mut state = begun(Target::Reversed);
    state.bind_pipeline(Some(static_pipeline()));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    state.before_draw(&mut sink);
    assert_eq!(
        sink,
        Recorded {
            viewports: vec![(0, vec![(1.0, 0.0)])],
            compare_ops: vec![vk::CompareOp::GREATER],
            biases: vec![DepthBias {
                constant: 1.0,
                clamp: -0.0,
                slope: 2.0,
                representation: None
            }],
            ..Default::default()
        }
    );
}

/// `VK_EXT_depth_clamp_control`: a user-defined clamp range holds depth values, sent mapped
/// like the bounds where the draw stores reversed depth and as it is where not; the viewport's
/// range goes down as such; a pipeline's static range revz made dynamic is sent at its bind.
#[test]
fn clamp_ranges_are_depth_values_mapped_for_reversed_draws() {
    let mut state = begun(Target::Reversed);
    state.bind_pipeline(Some(Arc::new(PipelineDepth {
        app_dynamic: States::CLAMP_RANGE,
        ..PipelineDepth::default()
    })));
    state.set_clamp_range(Some((0.25, 0.5)));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(sink.clamp_ranges, vec![Some((0.5, 0.75))]);
    state.set_target(Target::Native);
    state.before_draw(&mut sink);
    assert_eq!(sink.clamp_ranges.last(), Some(&Some((0.25, 0.5))));
    state.set_clamp_range(None);
    state.before_draw(&mut sink);
    assert_eq!(sink.clamp_ranges.last(), Some(&None));
    // Not sent again unchanged.
    let sent = sink.clamp_ranges.len();
    state.before_draw(&mut sink);
    assert_eq!(sink.clamp_ranges.len(), sent);

    let mut state = begun(Target::Reversed);
    state.bind_pipeline(Some(Arc::new(PipelineDepth {
        injected: States::CLAMP_RANGE,
        clamp_range: (0.0, 0.125),
        ..PipelineDepth::default()
    })));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(sink.clamp_ranges, vec![Some((0.875, 1.0))]);
    // A pipeline that leaves the range to the viewport sends none.
    let mut state = begun(Target::Reversed);
    state.bind_pipeline(Some(Arc::new(PipelineDepth::default())));
    state.set_clamp_range(Some((0.25, 0.5)));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert!(sink.clamp_ranges.is_empty());
}

#[test]
fn native_targets_get_the_application_values_unchanged() {
    let mut state = begun(Target::Native);
    state.bind_pipeline(Some(static_pipeline()));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(sink.viewports, vec![(0, vec![(0.0, 1.0)])]);
    assert_eq!(sink.compare_ops, vec![vk::CompareOp::LESS]);
    assert_eq!(sink.biases[0].constant, -1.0);
}

#[test]
fn application_dynamic_state_is_flipped_and_reemitted_when_the_target_changes() {
    let mut state = begun(Target::None);
    state.bind_pipeline(Some(Arc::new(PipelineDepth {
        app_dynamic: States::VIEWPORT | States::COMPARE_OP | States::BOUNDS,
        ..PipelineDepth::default()
    })));
    state.set_viewports(0, &[viewport(0.0, 0.5), viewport(0.5, 1.0)]);
    state.set_compare_op(vk::CompareOp::LESS_OR_EQUAL);
    state.set_bounds(0.0, 0.75);
    state.set_target(Target::Reversed);
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.5), (0.5, 0.0)])]);
    assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER_OR_EQUAL]);
    assert_eq!(sink.bounds, vec![(0.25, 1.0)]);

    state.set_target(Target::Native);
    state.before_draw(&mut sink);
    assert_eq!(sink.compare_ops.last(), Some(&vk::CompareOp::LESS_OR_EQUAL));
    assert_eq!(
        sink.viewports.last(),
        Some(&(0, vec![(0.0, 0.5), (0.5, 1.0)]))
    );
}

#[test]
fn only_viewports_the_application_set_are_emitted() {
    let mut state = begun(Target::Reversed);
    state.set_viewports(2, &[viewport(0.0, 0.1)]);
    state.set_viewports(4, &[viewport(0.0, 1.0), viewport(0.25, 0.5)]);
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(
        sink.viewports,
        vec![(2, vec![(1.0, 0.9)]), (4, vec![(1.0, 0.0), (0.75, 0.5)])]
    );
}

#[test]
fn states_the_pipeline_keeps_static_are_not_emitted() {
    let mut state = begun(Target::Reversed);
    state.set_compare_op(vk::CompareOp::LESS);
    state.set_viewports_with_count(&[viewport(0.0, 1.0)]);
    state.bind_pipeline(Some(Arc::new(PipelineDepth {
        app_dynamic: States::VIEWPORT_WITH_COUNT,
        ..PipelineDepth::default()
    })));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(sink.with_count, vec![vec![(1.0, 0.0)]]);
    assert!(sink.compare_ops.is_empty() && sink.viewports.is_empty());
}

#[test]
fn without_a_tracked_pipeline_every_set_state_is_emitted() {
    // Shader objects, or a pipeline revz could not read: the application's dynamic state
    // must still reach the driver.
    let mut state = begun(Target::Native);
    state.set_compare_op(vk::CompareOp::GREATER);
    state.set_bias(DepthBias {
        constant: 3.0,
        ..Default::default()
    });
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER]);
    assert_eq!(sink.biases.len(), 1);
}

fn perspective_bytes() -> Vec<u8> {
    let projection = glam::dcamera::rh::proj::vulkan::perspective(1.0, 1.5, 0.5, 50.0);
    projection
        .as_mat4()
        .to_cols_array()
        .iter()
        .flat_map(|v| v.to_ne_bytes())
        .collect()
}

const APP_PIPELINE: u64 = 8;
/// Push stages other than the carrier's range's: such pushes never carry the carrier.
const OTHER_STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
    vk::ShaderStageFlags::VERTEX.as_raw() | vk::ShaderStageFlags::FRAGMENT.as_raw(),
);

/// A pipeline reading its projection from push-constant bytes 0..64, whose vertex stage
/// stores the carrier's depth (carrier at byte 112).
fn projection_pipeline() -> Arc<PipelineDepth> {
    Arc::new(PipelineDepth {
        projection: Some(ProjectionUse {
            offset: 0,
            stride: 16,
            storage: revz_math::Storage::ColumnMajor,
            convention: revz_math::DepthConvention::ZeroToOne,
        }),
        position_store: Some(Carrier {
            offset: 112,
            stages: vk::ShaderStageFlags::VERTEX,
            range_offset: 0,
            push_patch: None,
        }),
        handle: vk::Pipeline::from_raw(APP_PIPELINE),
        ..(*static_pipeline()).clone()
    })
}

fn layout() -> vk::PipelineLayout {
    vk::PipelineLayout::from_raw(3)
}

fn precise(target: RewriteTarget) -> CommandState {
    let reversal = match target {
        RewriteTarget::Complementary => Reversal::Complementary,
        RewriteTarget::Infinite => Reversal::Infinite { near_over_far: 0.0 },
    };
    CommandState::new(Reversing {
        rewrite: Some(target),
        reversal,
    })
}

/// A pipeline whose vertex stage derives its range from a uniform buffer's matrix.
fn derived_pipeline() -> Arc<PipelineDepth> {
    Arc::new(PipelineDepth {
        projection: None,
        derived_range: Some(MatrixSource::UniformBuffer),
        layout: vk::PipelineLayout::from_raw(9),
        ..(*projection_pipeline()).clone()
    })
}

#[test]
fn a_stage_deriving_its_range_gets_the_selector_with_its_own_layout_and_no_push_of_its_own() {
    // Infinite mode stores n / w only where the CPU knows the n / f everything else on the
    // attachment maps with; without one (no camera pushed), complementary depth.
    let known = Reversal::Infinite {
        near_over_far: 0.01,
    };
    for (target, reversal, selector) in [
        (
            RewriteTarget::Complementary,
            Reversal::Complementary,
            1.0f32,
        ),
        (RewriteTarget::Infinite, known, 2.0),
        (
            RewriteTarget::Infinite,
            Reversal::Infinite { near_over_far: 0.0 },
            1.0,
        ),
    ] {
        let precise = |target| {
            CommandState::new(Reversing {
                rewrite: Some(target),
                reversal,
            })
        };
        let mut state = precise(target);
        state.begin(Target::Reversed, reversal, Default::default());
        state.bind_pipeline(Some(derived_pipeline()));
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        let carrier = Carrier::bytes(&[0.0, 0.0, 0.0, selector]).to_vec();
        assert_eq!(
            sink.pushed,
            vec![(vk::PipelineLayout::from_raw(9), carrier)]
        );
        assert_eq!(sink.viewports, vec![(0, vec![(0.0, 1.0)])]);
        assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER]);
        // The next draws: nothing more to send.
        state.before_draw(&mut sink);
        assert_eq!(sink.pushed.len(), 1);
        // Into a native attachment the stage stores its own z.
        state.set_target(Target::Native);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Native);
        let flip = Carrier::bytes(&FLIP_CARRIER).to_vec();
        assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&flip));
        // The application pushed with another pipeline's layout (an overlay's): the
        // selector still goes down with revz's layout of this pipeline's ranges.
        let mut state = precise(target);
        state.begin(Target::Reversed, reversal, Default::default());
        state.push_constants(layout(), OTHER_STAGES, 0, &[0; 16]);
        state.bind_pipeline(Some(derived_pipeline()));
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(
            sink.pushed.last().map(|p| p.0),
            Some(vk::PipelineLayout::from_raw(9))
        );
        // A secondary inheriting viewports cannot take it: the flip path.
        let mut inherited = precise(target);
        inherited.begin(Target::Reversed, reversal, Default::default());
        inherited.inherit_viewports();
        inherited.bind_pipeline(Some(derived_pipeline()));
        let mut sink = Recorded::default();
        inherited.before_draw(&mut sink);
        assert_eq!(inherited.path(), DrawPath::Flip);
    }
}

#[test]
fn depth_bounds_of_a_baked_precise_draw_map_as_complementary_depth() {
    // Infinite mode with a camera's n / f known: flip-path state maps with it, but a stage
    // with the carrier baked in stores complementary depth (found in review).
    let reversal = Reversal::Infinite {
        near_over_far: 0.01,
    };
    let mut state = CommandState::new(Reversing {
        rewrite: Some(RewriteTarget::Infinite),
        reversal,
    });
    state.begin(Target::Reversed, reversal, Default::default());
    let bounded = Arc::new(PipelineDepth {
        injected: States::VIEWPORT | States::BOUNDS,
        bounds: (0.25, 0.5),
        ..(*baked_pipeline()).clone()
    });
    state.bind_pipeline(Some(Arc::clone(&bounded)));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert_eq!(sink.bounds, vec![(0.5, 0.75)]);
    // On the flip path (a clamp turned on) the same bounds map with n / f.
    state.set_depth_clamp(true);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    assert_eq!(sink.bounds.last(), Some(&reversal.bounds(0.25, 0.5)));
}

/// A pipeline (20) whose layout has no room for the carrier: its reversed variant (21) and
/// promoted reversed variant (23) have the carrier baked in, its promoted variant (22) not.
fn baked_pipeline() -> Arc<PipelineDepth> {
    Arc::new(PipelineDepth {
        projection: None,
        position_store: None,
        derived_range: Some(MatrixSource::PushConstants),
        baked: true,
        layout: vk::PipelineLayout::null(),
        handle: vk::Pipeline::from_raw(20),
        reversed_variant: Some(vk::Pipeline::from_raw(21)),
        promotable: true,
        promoted_variant: Some(vk::Pipeline::from_raw(22)),
        promoted_reversed_variant: Some(vk::Pipeline::from_raw(23)),
        app_dynamic: States::DEPTH_CLAMP,
        ..(*projection_pipeline()).clone()
    })
}

#[test]
fn a_stage_with_the_carrier_baked_in_is_bound_for_precise_draws_only_and_nothing_is_pushed() {
    for target in [RewriteTarget::Complementary, RewriteTarget::Infinite] {
        let mut state = precise(target);
        let reversal = state.reversal();
        state.begin(Target::Reversed, reversal, Default::default());
        state.bind_pipeline(Some(baked_pipeline()));
        assert_eq!(
            state.pipeline_to_bind(vk::Pipeline::from_raw(20)),
            vk::Pipeline::from_raw(21),
            "the baked variant goes down in the bind's place"
        );
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        assert!(sink.pushed.is_empty(), "no push: the layout has no room");
        assert!(sink.binds.is_empty(), "bound with the bind");
        assert_eq!(sink.viewports, vec![(0, vec![(0.0, 1.0)])]);
        assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER]);

        // Into a native attachment: the application's pipeline and its own stage.
        state.set_target(Target::Native);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Native);
        assert_eq!(sink.binds, vec![vk::Pipeline::from_raw(20)]);
        // Into a promoted reversed one: the promoted variant with the baked stage.
        state.set_target(Target::Reversed);
        state.set_promoted(Some(vk::Format::D24_UNORM_S8_UINT));
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        assert_eq!(sink.binds.last(), Some(&vk::Pipeline::from_raw(23)));
        assert!(sink.pushed.is_empty());

        // A secondary inheriting viewports takes the flip path: the stages that store
        // the shader's own z (the baked one would store reversed depth the flip-path
        // viewport reverses again).
        let mut inherited = precise(target);
        inherited.begin(Target::Reversed, reversal, Default::default());
        inherited.inherit_viewports();
        inherited.bind_pipeline(Some(baked_pipeline()));
        assert_eq!(
            inherited.pipeline_to_bind(vk::Pipeline::from_raw(20)),
            vk::Pipeline::from_raw(20)
        );
        let mut sink = Recorded::default();
        inherited.before_draw(&mut sink);
        assert_eq!(inherited.path(), DrawPath::Flip);
        assert!(
            sink.binds.is_empty(),
            "the application's pipeline stays bound"
        );
        assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER]);
        inherited.set_promoted(Some(vk::Format::D24_UNORM_S8_UINT));
        inherited.before_draw(&mut sink);
        assert_eq!(sink.binds, vec![vk::Pipeline::from_raw(22)]);
    }
    // Infinite mode: a dynamic depth clamp turned on sends the draws to the flip path (the
    // far plane is gone on the precise one), and with them the application's stage.
    let mut state = precise(RewriteTarget::Infinite);
    let reversal = state.reversal();
    state.begin(Target::Reversed, reversal, Default::default());
    state.bind_pipeline(Some(baked_pipeline()));
    state.pipeline_to_bind(vk::Pipeline::from_raw(20));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    state.set_depth_clamp(true);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    assert_eq!(sink.binds, vec![vk::Pipeline::from_raw(20)]);
    state.set_depth_clamp(false);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert_eq!(
        sink.binds,
        vec![vk::Pipeline::from_raw(20), vk::Pipeline::from_raw(21)]
    );
    assert!(sink.pushed.is_empty());
}

#[test]
fn a_push_for_another_pipeline_is_never_overwritten_by_the_carrier() {
    // Bound: a pipeline whose stage derives its range (revz's layout 9). The application
    // then pushes 128 bytes with a layout of other ranges (no revz layout of its own), for
    // the pipeline it binds next: those bytes may cover the carrier's.
    let mut state = precise(RewriteTarget::Infinite);
    let reversal = state.reversal();
    state.begin(Target::Reversed, reversal, Default::default());
    state.bind_pipeline(Some(derived_pipeline()));
    let mut sink = Recorded::default();
    state.settle(&mut sink);
    assert_eq!(sink.pushed.len(), 1, "the selector, with revz's layout");
    state.note_push_pusher(vk::PipelineLayout::null(), None);
    let (_, folded) = state.push_constants(layout(), OTHER_STAGES, 0, &[0; 128]);
    assert!(
        folded.is_none(),
        "not extended with this pipeline's carrier"
    );
    state.settle(&mut sink);
    assert_eq!(
        sink.pushed.len(),
        1,
        "nothing pushed over the application's bytes"
    );
    // The application binds again (its next pipeline, here the same): the carrier its
    // push may have overwritten goes down again.
    state.bind_pipeline(Some(derived_pipeline()));
    state.settle(&mut sink);
    assert_eq!(sink.pushed.len(), 2);
    assert_eq!(
        sink.pushed.last().map(|p| p.0),
        Some(vk::PipelineLayout::from_raw(9))
    );
    assert_eq!(state.path(), DrawPath::Precise);
    // A push with a layout of the pipeline's own ranges is compatible: folded as before.
    state.note_push_pusher(vk::PipelineLayout::from_raw(9), None);
    state.push_constants(vk::PipelineLayout::from_raw(30), OTHER_STAGES, 0, &[0; 16]);
    state.settle(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
}

#[test]
fn a_dynamic_minus_one_to_one_convention_is_converted_by_the_stage_and_set_to_zero_to_one() {
    // Zink: the clip convention is dynamic and set [-1, 1] before each draw.
    let pipeline = Arc::new(PipelineDepth {
        app_dynamic: States::CLIP_CONTROL,
        ..(*derived_pipeline()).clone()
    });
    let reversal = Reversal::Infinite {
        near_over_far: 0.01,
    };
    let mut state = CommandState::new(Reversing {
        rewrite: Some(RewriteTarget::Infinite),
        reversal,
    });
    state.begin(Target::Reversed, reversal, Default::default());
    state.bind_pipeline(Some(pipeline));
    state.set_clip_negative_one_to_one(true);
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    let carrier = Carrier::bytes(&[0.0, 0.0, 0.0, 4.0]).to_vec();
    assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&carrier));
    assert_eq!(sink.clip_conventions, vec![false]);
    // Into a native attachment: the application's [-1, 1] and the shader's own z.
    state.set_target(Target::Native);
    state.before_draw(&mut sink);
    assert_eq!(sink.clip_conventions, vec![false, true]);
    let flip = Carrier::bytes(&FLIP_CARRIER).to_vec();
    assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&flip));
    // [0, 1] set by the application: selector 2, nothing converted.
    state.set_target(Target::Reversed);
    state.set_clip_negative_one_to_one(false);
    state.before_draw(&mut sink);
    let carrier = Carrier::bytes(&[0.0, 0.0, 0.0, 2.0]).to_vec();
    assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&carrier));
    assert_eq!(sink.clip_conventions, vec![false, true, false]);
}

#[test]
fn a_recording_looks_each_pipeline_up_once_until_the_device_destroys_one() {
    let mut state = begun(Target::Reversed);
    let depth = |raw: u64, compare_op: vk::CompareOp| {
        Arc::new(PipelineDepth {
            handle: vk::Pipeline::from_raw(raw),
            compare_op,
            ..(*static_pipeline()).clone()
        })
    };
    let lookups = std::cell::Cell::new(0);
    let bind =
        |state: &mut CommandState, raw: u64, generation: u64, found: Option<Arc<PipelineDepth>>| {
            state.bind_pipeline_handle(vk::Pipeline::from_raw(raw), generation, || {
                lookups.set(lookups.get() + 1);
                found
            });
            state.pipeline().map(|p| (p.handle.as_raw(), p.compare_op))
        };
    let (less, equal) = (vk::CompareOp::LESS, vk::CompareOp::EQUAL);
    assert_eq!(
        bind(&mut state, 1, 0, Some(depth(1, less))),
        Some((1, less))
    );
    assert_eq!(bind(&mut state, 2, 0, None), None, "untracked");
    assert_eq!(lookups.get(), 2);
    // Bound again: known, whatever a lookup would say.
    assert_eq!(bind(&mut state, 1, 0, None), Some((1, less)));
    assert_eq!(bind(&mut state, 2, 0, Some(depth(2, less))), None);
    assert_eq!(lookups.get(), 2);
    // A pipeline destroyed on the device (and its handle reused): looked up again.
    assert_eq!(
        bind(&mut state, 1, 1, Some(depth(1, equal))),
        Some((1, equal))
    );
    assert_eq!(lookups.get(), 3);
    // More pipelines than slots: each bind still gets its own.
    for raw in 10..20 {
        assert_eq!(
            bind(&mut state, raw, 1, Some(depth(raw, less))),
            Some((raw, less))
        );
    }
    assert_eq!(
        bind(&mut state, 1, 1, Some(depth(1, equal))),
        Some((1, equal))
    );
    // The settle after a bind sends the newly bound pipeline's flipped compare op.
    let mut sink = Recorded::default();
    state.settle(&mut sink);
    assert_eq!(sink.compare_ops.last(), Some(&vk::CompareOp::EQUAL));
}

#[test]
fn a_projection_takes_the_precise_path_through_the_carrier_pushed_once_per_camera() {
    let mut state = precise(RewriteTarget::Complementary);
    state.begin(
        Target::Reversed,
        Reversal::Complementary,
        Default::default(),
    );
    state.bind_pipeline(Some(projection_pipeline()));
    let data = perspective_bytes();
    // Pushed with other stages than the carrier's range: the draw sends the carrier.
    let (outcome, folded) = state.push_constants(layout(), OTHER_STAGES, 0, &data);
    assert!(matches!(outcome, Some(Outcome::Rewritten { .. })));
    assert!(folded.is_none());
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    // The application's bytes are never re-sent; only the carrier goes down, read by the
    // application's pipeline's own (rewritten) vertex stage: nothing else is bound.
    assert_eq!(sink.pushes, vec![(112, 16)]);
    assert!(sink.binds.is_empty());
    // [0, 1] -> [1 - 1, 1 - 0]: the rewritten store already reverses.
    assert_eq!(sink.viewports, vec![(0, vec![(0.0, 1.0)])]);
    assert_eq!(sink.compare_ops, vec![vk::CompareOp::GREATER]);

    // The next object's matrix of the same camera: nothing to send at its draw.
    state.push_constants(layout(), OTHER_STAGES, 0, &data);
    state.before_draw(&mut sink);
    assert_eq!(sink.pushes.len(), 1);
    assert_eq!(sink.viewports.len(), 1);
    // A push with another layout may have disturbed the carrier: it goes down again.
    state.push_constants(vk::PipelineLayout::from_raw(4), OTHER_STAGES, 0, &data);
    state.before_draw(&mut sink);
    assert_eq!(sink.pushes, vec![(112, 16), (112, 16)]);
}

#[test]
fn a_push_of_the_carriers_stages_carries_it_when_it_changes() {
    let mut state = precise(RewriteTarget::Infinite);
    state.begin(
        Target::Reversed,
        Reversal::Infinite { near_over_far: 0.0 },
        Default::default(),
    );
    state.bind_pipeline(Some(projection_pipeline()));
    let data = perspective_bytes();
    let (outcome, folded) = state.push_constants(layout(), vk::ShaderStageFlags::VERTEX, 0, &data);
    let Some(Outcome::Rewritten { carrier, .. }) = outcome else {
        panic!("{outcome:?}");
    };
    let folded = folded.expect("the carrier goes with the push");
    assert_eq!((folded.offset, folded.size), (0, 128));
    let mut out = [std::mem::MaybeUninit::new(0xAA); crate::precise::PUSH_CONSTANT_BYTES];
    let bytes = state.folded_bytes(&folded, &mut out);
    assert_eq!(bytes.len(), 128);
    assert_eq!(bytes[..64], data[..]);
    assert_eq!(bytes[64..112], [0; 48], "bytes never pushed");
    assert_eq!(bytes[112..128], Carrier::bytes(&carrier));
    // The draw has nothing to push; the same camera's next matrix goes down as it is.
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert!(sink.pushes.is_empty());
    let (_, again) = state.push_constants(layout(), vk::ShaderStageFlags::VERTEX, 0, &data);
    assert!(again.is_none());
    // Not sent extended (a caller that could not): the draw sends it.
    let (_, other) = state.push_constants(
        vk::PipelineLayout::from_raw(4),
        vk::ShaderStageFlags::VERTEX,
        0,
        &data,
    );
    assert!(other.is_some());
    state.unfold();
    state.before_draw(&mut sink);
    assert_eq!(sink.pushes, vec![(112, 16)]);
}

#[test]
fn without_a_push_layout_the_application_pipeline_draws_with_the_flip_path() {
    let mut state = precise(RewriteTarget::Complementary);
    state.begin(
        Target::Reversed,
        Reversal::Complementary,
        Default::default(),
    );
    state.bind_pipeline(Some(projection_pipeline()));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    assert!(sink.pushes.is_empty());
    assert!(
        sink.binds.is_empty(),
        "the application's pipeline stays bound"
    );
}

#[test]
fn viewports_go_down_before_secondaries_run_for_the_flip_path_they_inherit() {
    let mut state = precise(RewriteTarget::Complementary);
    state.begin(Target::None, Reversal::Complementary, Default::default());
    let mut sink = Recorded::default();
    // Nothing set: nothing to send.
    state.flush_viewports_for_secondaries(&mut sink);
    assert_eq!(sink, Recorded::default());
    // Set before a render pass of secondaries into a reversed attachment.
    state.set_viewports(0, &[viewport(0.0, 1.0)]);
    state.set_compare_op(vk::CompareOp::LESS);
    state.set_target(Target::Reversed);
    state.flush_viewports_for_secondaries(&mut sink);
    assert_eq!(
        sink,
        Recorded {
            viewports: vec![(0, vec![(1.0, 0.0)])],
            ..Default::default()
        },
        "only the viewports, flipped: nothing else is inherited"
    );
    state.set_secondary_contents(true);
    assert!(!state.records_inline());
    // Into a native attachment: the application's values.
    state.set_target(Target::Native);
    state.flush_viewports_for_secondaries(&mut sink);
    assert_eq!(sink.viewports.last(), Some(&(0, vec![(0.0, 1.0)])));
}

#[test]
fn a_secondary_inheriting_viewports_takes_the_flip_path_even_with_a_pushed_projection() {
    let mut state = precise(RewriteTarget::Complementary);
    state.begin(
        Target::Reversed,
        Reversal::Complementary,
        Default::default(),
    );
    state.inherit_viewports();
    state.bind_pipeline(Some(projection_pipeline()));
    state.push_constants(layout(), OTHER_STAGES, 0, &perspective_bytes());
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    // The variant is drawn with the flip carrier: the shader's own z.
    assert_eq!(sink.pushes, vec![(112, 16)]);
    // A new recording of the same command buffer forgets it.
    state.begin(
        Target::Reversed,
        Reversal::Complementary,
        Default::default(),
    );
    state.bind_pipeline(Some(projection_pipeline()));
    state.push_constants(layout(), OTHER_STAGES, 0, &perspective_bytes());
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
}

#[test]
fn draws_without_a_push_constant_projection_take_the_flip_path() {
    let mut state = precise(RewriteTarget::Complementary);
    state.begin(
        Target::Reversed,
        Reversal::Complementary,
        Default::default(),
    );
    state.bind_pipeline(Some(static_pipeline()));
    assert_eq!(
        state
            .push_constants(
                layout(),
                vk::ShaderStageFlags::VERTEX,
                0,
                &perspective_bytes()
            )
            .0,
        None,
        "not this pipeline's projection"
    );
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.0)])]);
}

#[test]
fn a_projection_pushed_outside_the_render_pass_is_classified_at_the_draw() {
    let mut state = precise(RewriteTarget::Infinite);
    state.begin(
        Target::None,
        Reversal::Infinite { near_over_far: 0.0 },
        Default::default(),
    );
    state.bind_pipeline(Some(projection_pipeline()));
    state.push_constants(
        layout(),
        vk::ShaderStageFlags::VERTEX,
        0,
        &perspective_bytes(),
    );
    state.set_target(Target::Reversed);
    let mut sink = Recorded::default();
    let outcome = state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert_eq!(sink.pushes, vec![(112, 16)]);
    // Infinite mode learned n / f = 0.01 from it, for the flip path's state.
    let Some(Outcome::Rewritten { near_over_far, .. }) = outcome else {
        panic!("{outcome:?}");
    };
    assert!((near_over_far - 0.01).abs() < 1e-6);
    assert_eq!(state.reversal(), Reversal::Infinite { near_over_far });
    // A camera of this recording's draws: what the pass's image remembers.
    assert_eq!(state.camera(), Some(near_over_far));

    // A flip-path pipeline in the same pass: nothing pushed, and its viewport maps
    // standard depth to n / w: [0, 1] -> [1, n / f].
    state.bind_pipeline(Some(static_pipeline()));
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    assert_eq!(sink.pushes.len(), 1);
    assert_eq!(
        sink.viewports.last(),
        Some(&(0, vec![(1.0, near_over_far)]))
    );

    // Native attachments get the carrier that keeps the shader's own z, and no flipped
    // state.
    state.bind_pipeline(Some(projection_pipeline()));
    state.set_target(Target::Native);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Native);
    assert_eq!(sink.pushes, vec![(112, 16), (112, 16)]);
    assert_eq!(sink.viewports.last(), Some(&(0, vec![(0.0, 1.0)])));
    assert_eq!(sink.compare_ops.last(), Some(&vk::CompareOp::LESS));
}

#[test]
fn rebinding_pipelines_with_the_same_state_sends_nothing_again() {
    let mut state = begun(Target::Reversed);
    let mut sink = Recorded::default();
    for _ in 0..3 {
        state.bind_pipeline(Some(static_pipeline()));
        state.before_draw(&mut sink);
    }
    assert_eq!(sink.viewports.len(), 1);
    assert_eq!(sink.compare_ops.len(), 1);
    assert_eq!(sink.biases.len(), 1);

    // A pipeline that keeps the compare op static overwrites it: after it, it is sent again.
    state.bind_pipeline(Some(Arc::new(PipelineDepth {
        injected: States::VIEWPORT | States::BIAS,
        ..(*static_pipeline()).clone()
    })));
    state.before_draw(&mut sink);
    state.bind_pipeline(Some(static_pipeline()));
    state.before_draw(&mut sink);
    assert_eq!(sink.viewports.len(), 1);
    assert_eq!(sink.compare_ops.len(), 2);

    // After secondaries ran, everything is sent again.
    state.invalidate();
    state.before_draw(&mut sink);
    assert_eq!(sink.viewports.len(), 2);
    assert_eq!(sink.compare_ops.len(), 3);
}

/// A pipeline `handle` with a reversed variant `handle + 1` whose compare op the variant
/// holds (`compare_op = variants`), its static viewport made dynamic.
fn compare_op_variant(handle: u64, compare_op: vk::CompareOp) -> Arc<PipelineDepth> {
    Arc::new(PipelineDepth {
        injected: States::VIEWPORT,
        viewports: vec![viewport(0.0, 1.0)],
        compare_op,
        handle: vk::Pipeline::from_raw(handle),
        reversed_variant: Some(vk::Pipeline::from_raw(handle + 1)),
        ..PipelineDepth::default()
    })
}

/// Binds `pipeline` as the hook does: found by handle, then its variant chosen.
fn bind(state: &mut CommandState, pipeline: &Arc<PipelineDepth>) -> vk::Pipeline {
    state.bind_pipeline_handle(pipeline.handle, 0, || Some(Arc::clone(pipeline)));
    state.pipeline_to_bind(pipeline.handle)
}

#[test]
fn binds_of_pipelines_that_settle_alike_need_no_settle() {
    // Two pipelines that differ only in what their variants hold.
    let less = compare_op_variant(20, vk::CompareOp::LESS);
    let less_or_equal = compare_op_variant(30, vk::CompareOp::LESS_OR_EQUAL);
    assert!(less.settles_like(&less_or_equal));
    let mut state = begun(Target::Reversed);
    let mut sink = Recorded::default();
    assert_eq!(bind(&mut state, &less), vk::Pipeline::from_raw(21));
    state.settle(&mut sink);
    assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.0)])]);
    let sent = sink.clone();
    // Alternating between them: each bind's variant goes down by the hook, and the state
    // stays clean (a settle would send the same viewport again, which the record drops).
    for (pipeline, variant) in [(&less_or_equal, 31), (&less, 21), (&less_or_equal, 31)] {
        assert_eq!(bind(&mut state, pipeline), vk::Pipeline::from_raw(variant));
        assert!(!state.wants_settle(), "bind of {variant}");
    }
    state.settle(&mut sink);
    assert_eq!(sink, sent);
    // The state the binds skipped settling is the one they left: a native pass then binds
    // the last pipeline itself back and sends its own viewport.
    state.set_target(Target::Native);
    state.settle(&mut sink);
    assert_eq!(sink.binds, vec![vk::Pipeline::from_raw(30)]);
    assert_eq!(
        sink.viewports,
        vec![(0, vec![(1.0, 0.0)]), (0, vec![(0.0, 1.0)])]
    );
    assert!(sink.compare_ops.is_empty());
}

#[test]
fn a_bind_of_a_pipeline_that_settles_otherwise_settles_again() {
    let dynamic_less = static_pipeline();
    let dynamic_greater = Arc::new(PipelineDepth {
        handle: vk::Pipeline::from_raw(40),
        compare_op: vk::CompareOp::GREATER,
        ..(*static_pipeline()).clone()
    });
    assert!(!dynamic_less.settles_like(&dynamic_greater));
    let mut state = begun(Target::Reversed);
    let mut sink = Recorded::default();
    state.bind_pipeline(Some(Arc::clone(&dynamic_less)));
    state.settle(&mut sink);
    bind(&mut state, &dynamic_greater);
    assert!(state.wants_settle());
    state.settle(&mut sink);
    assert_eq!(
        sink.compare_ops,
        vec![vk::CompareOp::GREATER, vk::CompareOp::LESS],
        "each pipeline's flipped compare op"
    );
    // An untracked pipeline after a tracked one: what the application set goes down again.
    state.bind_pipeline_handle(vk::Pipeline::from_raw(50), 0, || None);
    assert!(state.wants_settle());
    // And a tracked one after it, alike or not, settles again too.
    bind(&mut state, &dynamic_greater);
    assert!(state.wants_settle());
}

#[test]
fn a_bind_settles_again_where_the_state_was_not_settled_or_the_previous_slot_was_reused() {
    let pipelines: Vec<_> = (0..5)
        .map(|i| compare_op_variant(100 + 10 * i, vk::CompareOp::LESS))
        .collect();
    // Not settled since the last change: the bind leaves it to the settle.
    let mut state = begun(Target::Reversed);
    bind(&mut state, &pipelines[0]);
    state.set_compare_op(vk::CompareOp::LESS);
    bind(&mut state, &pipelines[1]);
    assert!(state.wants_settle());
    state.settle(&mut sink_of());
    // The recording's four slots hold 0..=3 (slot 0 next to be replaced); 0 is bound again,
    // then 4 replaces the slot of the bound pipeline: nothing to compare it with.
    for pipeline in &pipelines[..4] {
        bind(&mut state, pipeline);
        state.settle(&mut sink_of());
    }
    bind(&mut state, &pipelines[0]);
    assert!(!state.wants_settle());
    bind(&mut state, &pipelines[4]);
    assert!(
        state.wants_settle(),
        "the previous pipeline's slot was reused"
    );
    // Outside a pass nothing is settled, so nothing is clean either.
    let mut outside = CommandState::default();
    outside.begin(Target::None, Reversal::Complementary, Cameras::default());
    bind(&mut outside, &pipelines[0]);
    bind(&mut outside, &pipelines[1]);
    outside.set_target(Target::Reversed);
    assert!(outside.wants_settle());
}

fn sink_of() -> Recorded {
    Recorded::default()
}

/// [`static_pipeline`] changed by `change`.
fn static_pipeline_with(change: &dyn Fn(&mut PipelineDepth)) -> PipelineDepth {
    let mut pipeline = (*static_pipeline()).clone();
    change(&mut pipeline);
    pipeline
}

#[test]
fn settles_like_compares_what_revz_sends_and_nan_never_matches() {
    let base = static_pipeline();
    let with = static_pipeline_with;
    assert!(base.settles_like(&with(&|p| p.handle = vk::Pipeline::from_raw(9))));
    assert!(base.settles_like(&with(
        &|p| p.reversed_variant = Some(vk::Pipeline::from_raw(9))
    )));
    for changed in [
        with(&|p| p.app_dynamic = States::BOUNDS),
        with(&|p| p.injected = States::VIEWPORT),
        with(&|p| p.viewports = vec![viewport(0.0, 0.5)]),
        with(&|p| p.viewports.push(viewport(0.0, 1.0))),
        with(&|p| p.compare_op = vk::CompareOp::EQUAL),
        with(&|p| p.bias.constant = 3.0),
        with(&|p| p.bias.constant = f32::NAN),
        with(&|p| p.unreversed_fragment = true),
        with(&|p| p.layout = vk::PipelineLayout::from_raw(7)),
        with(&|p| {
            p.position_store = Some(crate::precise::Carrier {
                offset: 64,
                stages: vk::ShaderStageFlags::VERTEX,
                range_offset: 0,
                push_patch: None,
            })
        }),
    ] {
        assert!(!base.settles_like(&changed), "{changed:?}");
        assert!(!changed.settles_like(&base), "{changed:?}");
    }
    // A state revz leaves static is not compared: the bind sets it.
    let bounds_static = with(&|p| p.bounds = (0.2, 0.3));
    assert!(base.settles_like(&bounds_static));
    let nan = with(&|p| p.bias.slope = f32::NAN);
    assert!(!nan.settles_like(&nan.clone()), "a NaN is sent again");
}

#[test]
fn values_apart_names_the_states_whose_static_values_differ() {
    let base = static_pipeline();
    let with = static_pipeline_with;
    let apart = |p: &PipelineDepth| {
        let there = base.values_apart(p);
        assert_eq!(there, p.values_apart(&base), "symmetric: {p:?}");
        there
    };
    assert_eq!(
        apart(&with(&|p| p.handle = vk::Pipeline::from_raw(9))),
        Some(States::NONE)
    );
    assert_eq!(
        apart(&with(&|p| p.compare_op = vk::CompareOp::LESS_OR_EQUAL)),
        Some(States::COMPARE_OP)
    );
    assert_eq!(
        apart(&with(&|p| {
            p.compare_op = vk::CompareOp::GREATER;
            p.bias.slope = 1.0;
        })),
        Some(States::COMPARE_OP | States::BIAS)
    );
    // Injected bounds and clamp ranges, by bits; a NaN always differs.
    let ranged = with(&|p| {
        p.injected |= States::BOUNDS | States::CLAMP_RANGE;
        p.bounds = (0.25, 0.5);
    });
    let mut other = ranged.clone();
    other.clamp_range = (0.0, -0.0);
    assert_eq!(ranged.values_apart(&other), Some(States::CLAMP_RANGE));
    other.bounds = (0.25, f32::NAN);
    assert_eq!(
        ranged.values_apart(&other),
        Some(States::BOUNDS | States::CLAMP_RANGE)
    );
    let nan = other.clone();
    assert_eq!(nan.values_apart(&other), Some(States::BOUNDS));
    // Values of states revz leaves static are the bind's: nothing to send.
    assert_eq!(apart(&with(&|p| p.bounds = (0.2, 0.3))), Some(States::NONE));
    // A value state made dynamic in one of them only (a pipeline without depth bias beside
    // one with it): evaluated again.
    assert_eq!(
        apart(&with(&|p| p.injected = States::VIEWPORT)),
        Some(States::COMPARE_OP | States::BIAS)
    );
    assert_eq!(
        apart(&with(&|p| {
            p.injected = States::VIEWPORT | States::COMPARE_OP;
            p.compare_op = vk::CompareOp::EQUAL;
        })),
        Some(States::COMPARE_OP | States::BIAS)
    );
    // Anything else a settle reads: a full settle.
    for changed in [
        with(&|p| p.viewports = vec![viewport(0.0, 0.5)]),
        with(&|p| p.injected = States::COMPARE_OP | States::BIAS),
        with(&|p| p.app_dynamic = States::BIAS),
        with(&|p| p.layout = vk::PipelineLayout::from_raw(7)),
    ] {
        assert_eq!(apart(&changed), None, "{changed:?}");
    }
}

#[test]
fn a_bind_of_a_pipeline_apart_only_in_values_sends_those_values_alone() {
    // The bench's pair: a LESS and a LESS_OR_EQUAL pipeline, compare op and bias made
    // dynamic by revz, the same projection and carrier.
    let with = |handle: u64, op: vk::CompareOp, slope: f32| {
        Arc::new(PipelineDepth {
            handle: vk::Pipeline::from_raw(handle),
            compare_op: op,
            bias: DepthBias {
                slope,
                ..static_pipeline().bias
            },
            ..(*projection_pipeline()).clone()
        })
    };
    let less = with(60, vk::CompareOp::LESS, -2.0);
    let less_or_equal = with(70, vk::CompareOp::LESS_OR_EQUAL, -2.0);
    let biased = with(80, vk::CompareOp::LESS, -4.0);
    let mut state = precise(RewriteTarget::Complementary);
    state.begin(
        Target::Reversed,
        Reversal::Complementary,
        Cameras::default(),
    );
    let mut sink = Recorded::default();
    bind(&mut state, &less);
    state.push_constants(
        layout(),
        vk::ShaderStageFlags::VERTEX,
        0,
        &perspective_bytes(),
    );
    state.settle(&mut sink);
    // A push of the same bits takes the shortcut the settle wrote down.
    state.push_constants(
        layout(),
        vk::ShaderStageFlags::VERTEX,
        0,
        &perspective_bytes(),
    );
    state.settle(&mut sink);
    let settled = sink.clone();
    assert_eq!(settled.compare_ops, vec![vk::CompareOp::GREATER]);
    assert_eq!(state.path(), DrawPath::Precise);
    for (pipeline, op, slope) in [
        (&less_or_equal, vk::CompareOp::GREATER_OR_EQUAL, None),
        (&less, vk::CompareOp::GREATER, None),
        (&biased, vk::CompareOp::GREATER, Some(4.0)),
        (&less_or_equal, vk::CompareOp::GREATER_OR_EQUAL, Some(2.0)),
    ] {
        let before = sink.clone();
        bind(&mut state, pipeline);
        assert!(state.wants_settle());
        assert!(state.has_push_shortcut(), "the push shortcut stays");
        state.settle(&mut sink);
        assert!(!state.wants_settle());
        let mut expected = before.clone();
        if before.compare_ops.last() != Some(&op) {
            expected.compare_ops.push(op);
        }
        if let Some(slope) = slope {
            expected.biases.push(DepthBias {
                slope,
                ..*before.biases.last().unwrap()
            });
        }
        assert_eq!(
            sink, expected,
            "only the values that changed, after binding {pipeline:?}"
        );
        assert_eq!(state.path(), DrawPath::Precise);
    }
    // A pipeline whose bias revz leaves static (no depth bias): the bind sets its bias, and
    // the biased pipeline after it gets its own sent again.
    let unbiased = Arc::new(PipelineDepth {
        injected: States::VIEWPORT | States::COMPARE_OP,
        handle: vk::Pipeline::from_raw(90),
        ..(*less).clone()
    });
    let before = sink.clone();
    bind(&mut state, &unbiased);
    assert!(!state.dirty, "kept settled");
    state.settle(&mut sink);
    let mut expected = before.clone();
    expected.compare_ops.push(vk::CompareOp::GREATER);
    assert_eq!(sink, expected, "the compare op only");
    bind(&mut state, &less_or_equal);
    state.settle(&mut sink);
    expected.compare_ops.push(vk::CompareOp::GREATER_OR_EQUAL);
    expected.biases.push(*before.biases.last().unwrap());
    assert_eq!(
        sink, expected,
        "the bias again after the bind that set it statically"
    );
    // What the values path left is what a full settle finds: nothing more to send.
    state.set_compare_op(vk::CompareOp::NEVER);
    let before = sink.clone();
    state.settle(&mut sink);
    assert_eq!(sink, before);
}

#[test]
fn a_bind_kept_settled_forgets_what_was_sent_of_the_states_its_pipeline_sets_statically() {
    // Found in review: viewports flushed for secondaries (a subpass of secondaries that
    // executed none) are remembered as sent; a bind of a pipeline with static viewports
    // overwrites them even where it keeps the state settled, so a later pipeline with dynamic
    // viewports must get the application's again.
    let static_viewports = |handle: u64, op| {
        Arc::new(PipelineDepth {
            injected: States::COMPARE_OP,
            viewports: vec![viewport(0.0, 0.5)],
            compare_op: op,
            handle: vk::Pipeline::from_raw(handle),
            ..PipelineDepth::default()
        })
    };
    let (a, b) = (
        static_viewports(200, vk::CompareOp::LESS),
        static_viewports(210, vk::CompareOp::LESS_OR_EQUAL),
    );
    let dynamic = Arc::new(PipelineDepth {
        app_dynamic: States::VIEWPORT,
        handle: vk::Pipeline::from_raw(220),
        ..PipelineDepth::default()
    });
    let mut state = begun(Target::Reversed);
    let mut sink = Recorded::default();
    state.set_viewports(0, &[viewport(0.0, 1.0)]);
    bind(&mut state, &a);
    state.settle(&mut sink);
    state.flush_viewports_for_secondaries(&mut sink);
    assert_eq!(sink.viewports, vec![(0, vec![(1.0, 0.0)])]);
    state.settle(&mut sink);
    bind(&mut state, &b);
    assert!(!state.dirty, "kept settled");
    state.settle(&mut sink);
    bind(&mut state, &dynamic);
    state.set_viewports(0, &[viewport(0.0, 1.0)]);
    state.settle(&mut sink);
    assert_eq!(
        sink.viewports,
        vec![(0, vec![(1.0, 0.0)]), (0, vec![(1.0, 0.0)])],
        "the application's viewports again, after b's static ones"
    );
}

#[test]
fn an_infinite_mode_draw_that_clamps_depth_dynamically_takes_the_flip_path() {
    // Zink: the depth clamp is dynamic in every pipeline and enabled for GL_DEPTH_CLAMP.
    let pipeline = Arc::new(PipelineDepth {
        app_dynamic: States::DEPTH_CLAMP,
        ..(*derived_pipeline()).clone()
    });
    for (target, precise_while_clamped) in [
        (RewriteTarget::Infinite, false),
        (RewriteTarget::Complementary, true),
    ] {
        let mut state = precise(target);
        let reversal = state.reversal();
        state.begin(Target::Reversed, reversal, Default::default());
        state.bind_pipeline(Some(Arc::clone(&pipeline)));
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        state.set_depth_clamp(true);
        state.before_draw(&mut sink);
        let flip = Carrier::bytes(&FLIP_CARRIER).to_vec();
        if precise_while_clamped {
            // Complementary's precise path clamps at the far plane's 0 like the flip path.
            assert_eq!(state.path(), DrawPath::Precise);
        } else {
            assert_eq!(state.path(), DrawPath::Flip);
            // The rewritten stage stores its own z, which the flip-path viewport maps.
            assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&flip));
            assert_eq!(sink.viewports.last(), Some(&(0, vec![(1.0, 0.0)])));
        }
        state.set_depth_clamp(false);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
    }
    // A pipeline whose clamp is static is decided at its creation: the command's value
    // (for another pipeline) changes nothing here.
    let mut state = precise(RewriteTarget::Infinite);
    let reversal = state.reversal();
    state.begin(Target::Reversed, reversal, Default::default());
    state.set_depth_clamp(true);
    state.bind_pipeline(Some(derived_pipeline()));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
}

#[test]
fn an_infinite_mode_draw_that_clamps_depth_and_clips_it_keeps_the_precise_path() {
    // D3D translators: the clamp on with clipping kept on, statically (vkd3d) or dynamically.
    let static_clip = Arc::new(PipelineDepth {
        static_clamp: true,
        depth_clip: DepthClip::Static(true),
        ..(*derived_pipeline()).clone()
    });
    let dynamic_clip = Arc::new(PipelineDepth {
        static_clamp: true,
        depth_clip: DepthClip::Dynamic,
        ..(*derived_pipeline()).clone()
    });
    let begun_infinite = || {
        let mut state = precise(RewriteTarget::Infinite);
        let reversal = state.reversal();
        state.begin(Target::Reversed, reversal, Default::default());
        state
    };
    let mut sink = Recorded::default();
    let mut state = begun_infinite();
    state.bind_pipeline(Some(Arc::clone(&static_clip)));
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    // Clipping set dynamically: the value decides, per draw.
    let mut state = begun_infinite();
    state.bind_pipeline(Some(Arc::clone(&dynamic_clip)));
    state.set_depth_clip(true);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    state.set_depth_clip(false);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    state.set_depth_clip(true);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    // A pipeline that clamps without clipping (static, the spec's default) after one that
    // clips: the flip path, though every other state is alike (the bind's short settle must
    // not keep the precise path).
    let unclipped = Arc::new(PipelineDepth {
        static_clamp: true,
        depth_clip: DepthClip::Implied,
        ..(*derived_pipeline()).clone()
    });
    let mut state = begun_infinite();
    state.bind_pipeline(Some(Arc::clone(&static_clip)));
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    state.bind_pipeline(Some(unclipped));
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    // Shader objects: both dynamic; clipping unset follows the spec's default (off where
    // clamped).
    let pushed = Some((
        vk::ShaderEXT::from_raw(60),
        Some(PositionShader::Pushed {
            variant: vk::ShaderEXT::from_raw(61),
            depth: Arc::new(PipelineDepth {
                app_dynamic: States::ALL,
                ..(*derived_pipeline()).clone()
            }),
            projects_input: false,
        }),
    ));
    let mut state = begun_infinite();
    state.bind_shaders(None, [pushed, None, None, None]);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    state.set_depth_clamp(true);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    state.set_depth_clip(true);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
}

#[test]
fn pushes_reaching_an_extended_vertex_range_name_its_stages() {
    // A layout whose vertex range revz extended over the fragment range (VERTEX 0..64,
    // FRAGMENT 64..80, the carrier at 112): the fragment stage's pushes reach the extension.
    let patch = crate::precise::PushPatch {
        from: 64,
        to: 112,
        stages: vk::ShaderStageFlags::VERTEX,
    };
    let mut state = precise(RewriteTarget::Infinite);
    let fragment = vk::ShaderStageFlags::FRAGMENT;
    let vertex = vk::ShaderStageFlags::VERTEX;
    // Before a layout with a patch is noted: as the application sent them.
    assert_eq!(state.push_stages(64, 16, fragment), fragment);
    state.note_push_pusher(vk::PipelineLayout::from_raw(9), Some(patch));
    assert_eq!(state.push_stages(64, 16, fragment), fragment | vertex);
    assert_eq!(state.push_stages(0, 64, vertex), vertex);
    // Another layout, without one.
    state.note_push_pusher(vk::PipelineLayout::from_raw(10), None);
    assert_eq!(state.push_stages(64, 16, fragment), fragment);
}

#[test]
fn infinite_mode_without_a_known_near_over_far_derives_complementary_depth() {
    let unknown = Reversing {
        rewrite: Some(RewriteTarget::Infinite),
        reversal: Reversal::Infinite { near_over_far: 0.0 },
    };
    assert_eq!(unknown.derived_target(), Some(RewriteTarget::Complementary));
    let known = Reversing {
        reversal: Reversal::Infinite {
            near_over_far: 1e-3,
        },
        ..unknown
    };
    assert_eq!(known.derived_target(), Some(RewriteTarget::Infinite));
    let complementary = Reversing {
        rewrite: Some(RewriteTarget::Complementary),
        reversal: Reversal::Complementary,
    };
    assert_eq!(
        complementary.derived_target(),
        Some(RewriteTarget::Complementary)
    );
    assert_eq!(Reversing::default().derived_target(), None);
    // With n / f = 0, what the attachment's other state and the copies map with, the stored
    // 1 - D converts back to D exactly.
    for d in [0.0f32, 0.25, 0.999, 1.0] {
        let stored = 1.0 - d;
        assert_eq!(unknown.reversal.depth(d), stored);
    }
}

#[test]
fn only_a_camera_of_the_recordings_draws_is_one_an_image_remembers() {
    // Begun with the device's last seen n / f (maybe another camera's): not one.
    let seen = Reversal::Infinite {
        near_over_far: 0.08,
    };
    let mut state = precise(RewriteTarget::Infinite);
    state.begin(Target::Reversed, seen, Default::default());
    assert_eq!(state.camera(), None);
    // Entered from the pass's image: its own.
    state.enter_camera(0.01);
    assert_eq!(state.camera(), Some(0.01));
    assert_eq!(
        state.reversal(),
        Reversal::Infinite {
            near_over_far: 0.01
        }
    );
    // A new recording starts without one again.
    state.begin(Target::Reversed, seen, Default::default());
    assert_eq!(state.camera(), None);
    // Not in the other modes.
    let mut complementary = precise(RewriteTarget::Complementary);
    complementary.begin(
        Target::Reversed,
        Reversal::Complementary,
        Default::default(),
    );
    complementary.enter_camera(0.01);
    assert_eq!(complementary.camera(), None);
    assert_eq!(complementary.reversal(), Reversal::Complementary);
}

#[test]
fn an_infinite_mode_target_of_complementary_depth_is_drawn_as_complementary_mode_draws() {
    // An image read as an input attachment stores 1 - D in infinite mode: a stage that
    // derives its range stores complementary depth there (selector 1), while the recording's
    // camera (n / f = 0.01) stays what its other targets map with.
    let reversal = Reversal::Infinite {
        near_over_far: 0.01,
    };
    let mut state = CommandState::new(Reversing {
        rewrite: Some(RewriteTarget::Infinite),
        reversal,
    });
    state.begin(Target::Reversed, reversal, Default::default());
    state.bind_pipeline(Some(derived_pipeline()));
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    let infinite = Carrier::bytes(&[0.0, 0.0, 0.0, 2.0]).to_vec();
    assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&infinite));
    state.set_complementary_target(true);
    state.before_draw(&mut sink);
    let complementary = Carrier::bytes(&[0.0, 0.0, 0.0, 1.0]).to_vec();
    assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&complementary));
    assert_eq!(state.reversal(), reversal, "the recording's camera is kept");
    assert_eq!(state.target_reversing().reversal, Reversal::Complementary);
    // Leaving the pass ends it: the next target maps with the camera again.
    state.leave_pass();
    state.set_target(Target::Reversed);
    state.before_draw(&mut sink);
    assert_eq!(sink.pushed.last().map(|p| &p.1), Some(&infinite));
}

/// The push shortcut changes nothing the full path would not: in random recordings (pushes of
/// two cameras' P * V * M, of bytes beside the projection and of a second layout; binds of
/// pipelines with and without a pushed projection, and of one whose stage derives its range;
/// target changes, cameras entered from images, complementary targets, and draws), every
/// push the shortcut takes leaves the state as the full path (`push_constants` then a settle)
/// leaves a copy of it, byte for byte of its debug form, and neither sends anything for it.
/// Most pushes of the same camera must take it.
#[test]
fn the_push_shortcut_leaves_the_state_as_the_full_path_does() {
    use glam::dcamera::rh::{proj::vulkan, view::look_at_mat4};
    use glam::{DMat4, DVec3};
    let cameras = [
        (DVec3::new(30.0, 20.0, 50.0), 0.1, 100.0),
        (DVec3::new(-400.0, 15.0, 90.0), 0.5, 5.0e4),
    ];
    let mvp = |camera: usize, at: DVec3| -> Vec<u8> {
        let (eye, near, far) = cameras[camera];
        let view = look_at_mat4(eye, DVec3::ZERO, DVec3::Y);
        (vulkan::perspective(1.0, 1.5, near, far) * view * DMat4::from_translation(at))
            .as_mat4()
            .to_cols_array()
            .iter()
            .flat_map(|v| v.to_ne_bytes())
            .collect()
    };
    let flip_only = Arc::new(PipelineDepth {
        projection: None,
        handle: vk::Pipeline::from_raw(APP_PIPELINE + 1),
        ..(*projection_pipeline()).clone()
    });
    // Apart from the first only in values (a bind between them keeps the shortcut).
    let less_or_equal = Arc::new(PipelineDepth {
        compare_op: vk::CompareOp::LESS_OR_EQUAL,
        handle: vk::Pipeline::from_raw(APP_PIPELINE + 2),
        ..(*projection_pipeline()).clone()
    });
    // Viewports the application sets (sent for secondaries too, below).
    let dynamic_viewports = Arc::new(PipelineDepth {
        app_dynamic: States::VIEWPORT,
        injected: States::COMPARE_OP | States::BIAS,
        handle: vk::Pipeline::from_raw(APP_PIPELINE + 3),
        ..(*projection_pipeline()).clone()
    });
    // Static viewports revz leaves static, a pair apart only in its compare op.
    let viewports_static = |handle: u64, op| {
        Arc::new(PipelineDepth {
            injected: States::COMPARE_OP,
            viewports: vec![viewport(0.0, 0.5)],
            compare_op: op,
            handle: vk::Pipeline::from_raw(handle),
            ..PipelineDepth::default()
        })
    };
    // Without depth bias (revz leaves it static): apart from the first in the states made
    // dynamic, a bind between them keeps the shortcut too.
    let unbiased = Arc::new(PipelineDepth {
        injected: States::VIEWPORT | States::COMPARE_OP,
        compare_op: vk::CompareOp::GREATER_OR_EQUAL,
        handle: vk::Pipeline::from_raw(APP_PIPELINE + 6),
        ..(*projection_pipeline()).clone()
    });
    let pipelines = [
        projection_pipeline(),
        flip_only,
        static_pipeline(),
        derived_pipeline(),
        less_or_equal,
        unbiased,
        dynamic_viewports,
        viewports_static(APP_PIPELINE + 4, vk::CompareOp::LESS),
        viewports_static(APP_PIPELINE + 5, vk::CompareOp::GREATER),
        // A later stage whose pushed projection the CPU classifies, its fit kept (issue #41).
        Arc::new(PipelineDepth {
            handle: vk::Pipeline::from_raw(APP_PIPELINE + 7),
            ..(*classified_and_derived_pipeline()).clone()
        }),
    ];
    let layouts = [layout(), vk::PipelineLayout::from_raw(4)];
    for target in [RewriteTarget::Complementary, RewriteTarget::Infinite] {
        let mut state = precise(target);
        let reversal = precise(target).reversal();
        state.begin(Target::Reversed, reversal, Cameras::default());
        state.set_viewports(0, &[viewport(0.0, 1.0)]);
        state.bind_pipeline(Some(Arc::clone(&pipelines[0])));
        let mut random = 0x9e37_79b9_7f4a_7c15u64;
        let (mut taken, mut same_camera_pushes, mut values_binds) = (0, 0, 0);
        for step in 0..4000 {
            random ^= random << 13;
            random ^= random >> 7;
            random ^= random << 17;
            let pick = random % 100;
            let mut sink = Recorded::default();
            if pick < 80 {
                let camera = usize::from(step % 400 >= 300);
                let at = DVec3::new(
                    (random >> 8) as f64 % 40.0 - 20.0,
                    (random >> 20) as f64 % 10.0,
                    -((random >> 32) as f64 % 60.0),
                );
                let (layout, offset, bytes) = match random % 23 {
                    0 => (layouts[1], 0, mvp(camera, at)),
                    1 | 2 => (layouts[0], 64, vec![7; 16]),
                    3 => (layouts[0], 32, mvp(camera, at)[..16].to_vec()),
                    _ => (layouts[0], 0, mvp(camera, at)),
                };
                let stages = if random % 5 == 0 {
                    vk::ShaderStageFlags::VERTEX
                } else {
                    OTHER_STAGES
                };
                same_camera_pushes += usize::from(offset == 0 && layout == layouts[0]);
                let mut full = state.clone();
                if layout != full.push_layout() {
                    full.note_push_pusher(vk::PipelineLayout::null(), None);
                }
                let full_stages = full.push_stages(offset, bytes.len() as u32, stages);
                let (_, folded) = full.push_constants(layout, full_stages, offset, &bytes);
                let mut full_sink = Recorded::default();
                full.settle(&mut full_sink);
                match state.push_shortcut(layout, stages, offset, &bytes) {
                    Some(sent) => {
                        taken += 1;
                        assert_eq!(sent, full_stages, "step {step}");
                        assert!(folded.is_none(), "step {step}: the full path folds");
                        assert_eq!(full_sink, Recorded::default(), "step {step}");
                        state.settle(&mut sink);
                        assert_eq!(sink, Recorded::default(), "step {step}");
                        assert_eq!(format!("{state:?}"), format!("{full:?}"), "step {step}");
                    }
                    None => {
                        // The full path after the shortcut declined ends where it ends alone
                        // (what the shortcut did is what it does first, or fills its cache).
                        if layout != state.push_layout() {
                            state.note_push_pusher(vk::PipelineLayout::null(), None);
                        }
                        let stages = state.push_stages(offset, bytes.len() as u32, stages);
                        let (_, after) = state.push_constants(layout, stages, offset, &bytes);
                        state.settle(&mut sink);
                        assert_eq!((after, &sink), (folded, &full_sink), "step {step}");
                        assert_eq!(format!("{state:?}"), format!("{full:?}"), "step {step}");
                    }
                }
            } else if pick < 88 {
                let pipeline = &pipelines[(random >> 9) as usize % pipelines.len()];
                // A bind that leaves the state settled sends what a full settle after the
                // bind would, and leaves the state as that does.
                let mut full = state.clone();
                full.bind_pipeline_unsettled(Some(Arc::clone(pipeline)));
                let mut full_sink = Recorded::default();
                full.settle(&mut full_sink);
                state.bind_pipeline(Some(Arc::clone(pipeline)));
                values_binds += usize::from(!state.dirty);
                state.settle(&mut sink);
                assert_eq!(sink, full_sink, "step {step}");
                let without_shortcut = |state: &CommandState| {
                    let mut state = state.clone();
                    state.drop_shortcut();
                    format!("{state:?}")
                };
                assert_eq!(
                    without_shortcut(&state),
                    without_shortcut(&full),
                    "step {step}"
                );
            } else if pick < 91 {
                let to = if random % 2 == 0 {
                    Target::Native
                } else {
                    Target::Reversed
                };
                state.set_target(to);
                state.settle(&mut sink);
            } else if pick < 93 {
                // A pass into an image that remembered a camera, or one storing complementary
                // depth (infinite mode).
                if random % 2 == 0 {
                    state.enter_camera([0.001, 1e-5][(random >> 5) as usize % 2]);
                } else {
                    state.set_complementary_target((random >> 5) % 2 == 0);
                }
                state.settle(&mut sink);
            } else if pick < 95 {
                // The application's viewports, and down for secondaries (remembered as
                // sent).
                let max_depth = if random % 2 == 0 { 1.0 } else { 0.75 };
                state.set_viewports(0, &[viewport(0.0, max_depth)]);
                state.flush_viewports_for_secondaries(&mut sink);
                state.settle(&mut sink);
            } else {
                state.before_draw(&mut sink);
            }
        }
        eprintln!(
            "{target:?}: {taken} shortcuts, {same_camera_pushes} projection pushes, \
             {values_binds} binds kept settled"
        );
        assert!(
            values_binds >= 20,
            "{target:?}: {values_binds} binds kept settled"
        );
        assert!(
            taken * 10 >= same_camera_pushes * 6,
            "{target:?}: {taken} shortcuts of {same_camera_pushes} pushes of a projection"
        );
    }
}

/// A pipeline whose later stage fits the matrix it loads from push-constant bytes 0..64, which
/// the CPU classifies too (issue #41: a mesh, geometry or tessellation evaluation stage's
/// push-constant projection).
fn classified_and_derived_pipeline() -> Arc<PipelineDepth> {
    Arc::new(PipelineDepth {
        derived_range: Some(MatrixSource::PushConstants),
        ..(*projection_pipeline()).clone()
    })
}

#[test]
fn a_stage_fitting_a_pushed_matrix_the_cpu_classifies_gets_the_cameras_line_else_its_fit() {
    for target in [RewriteTarget::Complementary, RewriteTarget::Infinite] {
        let mut state = precise(target);
        let reversal = state.reversal();
        state.begin(Target::Reversed, reversal, Default::default());
        state.bind_pipeline(Some(classified_and_derived_pipeline()));
        // A camera's projection: its line (selector 0, the stage keeps it), as a vertex
        // stage's pushed projection gets.
        state.push_constants(layout(), OTHER_STAGES, 0, &perspective_bytes());
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        let (_, carrier) = sink.pushed.last().expect("the carrier goes down").clone();
        let values: Vec<f32> = carrier
            .chunks_exact(4)
            .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        assert_eq!(values[3], 0.0, "selector 0: the pushed line");
        assert_ne!(values[1..3], [0.0, 0.0], "the camera's k and B");
        // An affine matrix (no camera): the stage's own fit, its selector.
        let mut affine = [0u8; 64];
        for (i, v) in [
            1.0f32, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.5, 1.0,
        ]
        .iter()
        .enumerate()
        {
            affine[i * 4..i * 4 + 4].copy_from_slice(&v.to_ne_bytes());
        }
        state.push_constants(layout(), OTHER_STAGES, 0, &affine);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise);
        let (_, carrier) = sink.pushed.last().unwrap().clone();
        let selector = f32::from_ne_bytes(carrier[12..16].try_into().unwrap());
        assert!(selector >= 1.0, "the fit's selector: {selector}");
        // The next affine matrices (a shadow pass's objects) keep the fit's path: each is
        // classified (no camera), but the state stays settled and nothing is sent (found in
        // review: each marked the state dirty, its path computed as flip); the same matrix
        // again takes the push shortcut.
        let sent = sink.clone();
        for step in 1..4u8 {
            let mut next = affine;
            next[48..52].copy_from_slice(&f32::from(step).to_ne_bytes());
            let (outcome, folded) = state.push_constants(layout(), OTHER_STAGES, 0, &next);
            assert_eq!(
                (outcome, folded),
                (Some(Outcome::Unchanged), None),
                "step {step}"
            );
            assert!(!state.wants_settle(), "step {step}");
            assert_eq!(
                state.push_shortcut(layout(), OTHER_STAGES, 0, &next),
                Some(OTHER_STAGES),
                "step {step}"
            );
        }
        state.before_draw(&mut sink);
        assert_eq!(sink, sent);
        assert_eq!(state.path(), DrawPath::Precise);
    }
}

#[test]
fn a_mesh_shader_bound_over_a_vertex_shaders_variant_gets_the_vertex_shader_put_back() {
    // Found in review: the mesh shader's variant substituted in the application's bind left
    // the vertex stage's variant bound, which later native or flip-path draws would run.
    let (vertex, vertex_variant) = (vk::ShaderEXT::from_raw(40), vk::ShaderEXT::from_raw(41));
    let (mesh, mesh_variant) = (vk::ShaderEXT::from_raw(43), vk::ShaderEXT::from_raw(44));
    let (vertex_stage, mesh_stage) = (vk::ShaderStageFlags::VERTEX, vk::ShaderStageFlags::MESH_EXT);
    let mut state = precise(RewriteTarget::Complementary);
    let reversal = state.reversal();
    state.begin(Target::Reversed, reversal, Default::default());
    let baked = |shader, variant| {
        Some((
            shader,
            Some(PositionShader::Baked {
                variant,
                projects_input: false,
            }),
        ))
    };
    state.bind_shaders(None, [baked(vertex, vertex_variant), None, None, None]);
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(sink.position_shader_binds, [(vertex_stage, vertex_variant)]);
    // The mesh shader's bind goes down as the application made it: not substituted.
    state.bind_shaders(None, [None, None, None, baked(mesh, mesh_variant)]);
    assert_eq!(state.position_shader_to_bind(), None);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert_eq!(
        sink.position_shader_binds[1..],
        [(vertex_stage, vertex), (mesh_stage, mesh_variant)],
        "the vertex shader back, then the mesh shader's variant"
    );
    // The mesh stage unbound by the application (its bind replaces revz's variant there):
    // the vertex stage's variant again, with the settle (the call names no vertex stage).
    state.bind_shaders(
        None,
        [None, None, None, Some((vk::ShaderEXT::null(), None))],
    );
    state.before_draw(&mut sink);
    assert_eq!(
        sink.position_shader_binds[3..],
        [(vertex_stage, vertex_variant)]
    );
    // Into a native attachment: the application's vertex shader.
    state.set_target(Target::Native);
    state.before_draw(&mut sink);
    assert_eq!(
        sink.position_shader_binds.last(),
        Some(&(vertex_stage, vertex))
    );
}

/// A vertex shader object of the pushed route: its projection at push-constant bytes 0..64
/// and the carrier at 112, pushed with revz's layout of its ranges (`own`).
fn pushed_shader(variant: vk::ShaderEXT, own: vk::PipelineLayout) -> PositionShader {
    PositionShader::Pushed {
        variant,
        depth: Arc::new(PipelineDepth {
            app_dynamic: States::ALL,
            injected: States::NONE,
            handle: vk::Pipeline::null(),
            layout: own,
            ..(*projection_pipeline()).clone()
        }),
        projects_input: false,
    }
}

#[test]
fn a_pushed_vertex_shader_object_classifies_its_projection_and_binds_its_variant_for_precise_draws()
{
    let vertex = vk::ShaderEXT::from_raw(50);
    let variant = vk::ShaderEXT::from_raw(51);
    let own = vk::PipelineLayout::from_raw(9);
    let stage = vk::ShaderStageFlags::VERTEX;
    let pushed = Some((vertex, Some(pushed_shader(variant, own))));
    let camera = perspective_bytes();
    // An orthographic matrix (a shadow pass's): no camera, the flip path.
    let ortho: Vec<u8> =
        glam::dcamera::rh::proj::vulkan::orthographic(-1.0, 1.0, -1.0, 1.0, 0.5, 50.0)
            .as_mat4()
            .to_cols_array()
            .iter()
            .flat_map(|v| v.to_ne_bytes())
            .collect();
    for target in [RewriteTarget::Complementary, RewriteTarget::Infinite] {
        let mut state = precise(target);
        let reversal = state.reversal();
        state.begin(Target::Reversed, reversal, Default::default());
        state.bind_shaders(None, [pushed.clone(), None, None, None]);
        state.set_compare_op(vk::CompareOp::LESS);
        // Pushed with a layout whose ranges revz's layout has (compatible).
        state.note_push_pusher(own, None);
        let (outcome, _) = state.push_constants(layout(), OTHER_STAGES, 0, &camera);
        let Some(Outcome::Rewritten { carrier, .. }) = outcome else {
            panic!("{target:?}: the camera's projection classified: {outcome:?}");
        };
        let mut sink = Recorded::default();
        state.before_draw(&mut sink);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise, "{target:?}");
        // The camera's carrier, once, with the application's push layout; the variant that
        // reads it, once.
        assert_eq!(
            sink.pushed,
            [(layout(), Carrier::bytes(&carrier).to_vec())],
            "{target:?}"
        );
        assert_eq!(sink.position_shader_binds, [(stage, variant)], "{target:?}");
        assert_eq!(sink.compare_ops.last(), Some(&vk::CompareOp::GREATER));
        // The next object's matrix of the same camera: nothing sent.
        state.push_constants(layout(), OTHER_STAGES, 0, &camera);
        state.before_draw(&mut sink);
        assert_eq!(sink.pushed.len(), 1);
        assert_eq!(sink.position_shader_binds.len(), 1);
        // An orthographic matrix: the flip path, with the application's shader back (its
        // code stores its own z; the carrier is not read).
        state.push_constants(layout(), OTHER_STAGES, 0, &ortho);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip, "{target:?}");
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, vertex)));
        state.push_constants(layout(), OTHER_STAGES, 0, &camera);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise, "{target:?}");
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, variant)));
        // A [-1, 1] clip convention set by the application: the projection was classified
        // for [0, 1], so the flip path.
        state.set_clip_negative_one_to_one(true);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip, "{target:?}");
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, vertex)));
        state.set_clip_negative_one_to_one(false);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise, "{target:?}");
        // A geometry shader without a variant after it is rasterized: the flip path, the
        // application's vertex shader bound.
        let geometry = vk::ShaderEXT::from_raw(52);
        state.bind_shaders(None, [None, None, Some((geometry, None)), None]);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip, "{target:?}");
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, vertex)));
        state.bind_shaders(
            None,
            [None, None, Some((vk::ShaderEXT::null(), None)), None],
        );
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Precise, "{target:?}");
        // A native attachment: the application's shader, the application's depth state.
        state.set_target(Target::Native);
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Native);
        assert_eq!(sink.position_shader_binds.last(), Some(&(stage, vertex)));
        // A pipeline bound replaces the shader objects: the pipeline's facts again.
        state.set_target(Target::Reversed);
        state.bind_pipeline(Some(static_pipeline()));
        state.before_draw(&mut sink);
        assert_eq!(state.path(), DrawPath::Flip, "{target:?}");
    }
    // Pushed before any push of the application's: the carrier waits for the projection, and
    // the draw takes the flip path with the application's shader.
    let mut state = precise(RewriteTarget::Complementary);
    state.begin(
        Target::Reversed,
        Reversal::Complementary,
        Default::default(),
    );
    state.bind_shaders(None, [pushed, None, None, None]);
    let mut sink = Recorded::default();
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    assert!(sink.position_shader_binds.is_empty());
}

#[test]
fn a_shader_object_projecting_gl_in_is_precise_only_after_a_stage_storing_w_one() {
    // Shader objects pair only at draw time: a geometry or evaluation shader whose variant
    // projects the previous stage's Position (assuming its w = 1) is bound only where the
    // shaders bound before it give w = 1, as a pipeline checks at its creation.
    let vertex_unit_w = vk::ShaderEXT::from_raw(50);
    let vertex_projecting = vk::ShaderEXT::from_raw(51);
    let (evaluation, evaluation_variant) =
        (vk::ShaderEXT::from_raw(52), vk::ShaderEXT::from_raw(53));
    let interpolating = vk::ShaderEXT::from_raw(54);
    let (geometry, geometry_variant) = (vk::ShaderEXT::from_raw(55), vk::ShaderEXT::from_raw(56));
    let flip = |shader, stores_unit_w| Some((shader, Some(PositionShader::Flip { stores_unit_w })));
    let projecting = |shader, variant| {
        Some((
            shader,
            Some(PositionShader::Baked {
                variant,
                projects_input: true,
            }),
        ))
    };
    let unbound = Some((vk::ShaderEXT::null(), None));
    let geometry_stage = vk::ShaderStageFlags::GEOMETRY;
    let evaluation_stage = vk::ShaderStageFlags::TESSELLATION_EVALUATION;
    let mut state = precise(RewriteTarget::Infinite);
    let reversal = state.reversal();
    state.begin(Target::Reversed, reversal, Default::default());
    let mut sink = Recorded::default();

    // Geometry after a vertex shader storing vec4(p, 1.0): its variant, the precise path.
    state.bind_shaders(
        None,
        [
            flip(vertex_unit_w, true),
            unbound.clone(),
            projecting(geometry, geometry_variant),
            unbound.clone(),
        ],
    );
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert_eq!(
        sink.position_shader_binds,
        [(geometry_stage, geometry_variant)]
    );
    // A vertex shader whose w is not shown to be 1: the flip path, the application's shader.
    state.bind_shaders(None, [flip(vertex_projecting, false), None, None, None]);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Flip);
    assert_eq!(
        sink.position_shader_binds.last(),
        Some(&(geometry_stage, geometry))
    );
    assert_eq!(state.position_shader_to_bind(), None);
    // Back to one storing w = 1.
    state.bind_shaders(None, [flip(vertex_unit_w, true), None, None, None]);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert_eq!(
        sink.position_shader_binds.last(),
        Some(&(geometry_stage, geometry_variant))
    );

    // Geometry after an evaluation shader interpolating the patch: w = 1 only with a control
    // shader copying the positions of a vertex shader storing w = 1.
    state.bind_shaders(
        None,
        [
            None,
            Some((interpolating, Some(PositionShader::PassesThrough))),
            None,
            None,
        ],
    );
    state.before_draw(&mut sink);
    assert_eq!(
        state.path(),
        DrawPath::Flip,
        "no control shader copying the positions"
    );
    state.bind_control_shader(true);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert_eq!(
        sink.position_shader_binds.last(),
        Some(&(geometry_stage, geometry_variant))
    );
    state.bind_shaders(None, [flip(vertex_projecting, false), None, None, None]);
    state.before_draw(&mut sink);
    assert_eq!(
        state.path(),
        DrawPath::Flip,
        "the vertex shader's w not shown"
    );
    // An evaluation shader storing w = 1 itself, whatever came before it.
    state.bind_shaders(None, [None, flip(interpolating, true), None, None]);
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);

    // An evaluation shader projecting the patch's positions, the last stage: the control
    // shader must copy a vertex shader's vec4(p, 1.0).
    state.bind_shaders(
        None,
        [
            flip(vertex_unit_w, true),
            projecting(evaluation, evaluation_variant),
            unbound.clone(),
            None,
        ],
    );
    state.before_draw(&mut sink);
    assert_eq!(state.path(), DrawPath::Precise);
    assert_eq!(
        sink.position_shader_binds.last(),
        Some(&(evaluation_stage, evaluation_variant))
    );
    state.bind_control_shader(false);
    state.before_draw(&mut sink);
    assert_eq!(
        state.path(),
        DrawPath::Flip,
        "a control shader changing the positions"
    );
    assert_eq!(
        sink.position_shader_binds.last(),
        Some(&(evaluation_stage, evaluation))
    );
}
