//! The scenes of passes and command buffers: secondaries, subpasses, dynamic rendering, the
//! shadow map, multisample resolves, fragment depth and pipeline libraries.

use super::*;

/// `secondary`: the overlap scene's draws recorded into two secondary command buffers
/// (RENDER_PASS_CONTINUE, inheritance naming the render pass, subpass 0 and the framebuffer;
/// each binds the pipeline itself), executed with one `vkCmdExecuteCommands` in a pass begun
/// with SECONDARY_COMMAND_BUFFERS contents. The image is exactly the overlap image.
///
/// Layer item: per-command-buffer state in secondaries (DESIGN.md pitfall 9): pipelines
/// bound and push constants written inside secondary command buffers must be handled like
/// primary ones. Missed, the secondaries' draws keep standard depth against a reversed clear
/// and compare: the occlusion order inverts (far cubes over near ones) or nothing draws.
pub fn secondary() -> Scene {
    let mut scene = overlap();
    scene.name = "secondary";
    let draws: Vec<Step> = (0..scene.objects.len()).map(Step::Draw).collect();
    let (first, second) = draws.split_at(2);
    let record = |draws: &[Step]| {
        let mut steps = vec![Step::Bind(0)];
        steps.extend_from_slice(draws);
        steps
    };
    scene.plan.steps = vec![
        Step::BeginPass(0),
        Step::ExecuteSecondaries(vec![record(first), record(second)], Recording::MainThread),
        Step::EndPass,
    ];
    scene
}

/// `dynamic-rendering-secondaries`: `secondary` in a dynamic rendering
/// (`VK_RENDERING_CONTENTS_SECONDARY_COMMAND_BUFFERS_BIT`), its two secondaries recorded at
/// once on threads of their own, each inheriting the rendering's formats
/// (`VkCommandBufferInheritanceRenderingInfo`: no render pass, no framebuffer), as
/// multi-threaded engines on dynamic rendering record their draws.
///
/// Layer item: a secondary that inherits only formats says nothing of the image it draws
/// into: a layer must take the depth target (and, for D16 and D24, the promoted format its
/// pipelines and inheritance must name) from the format, or the secondary's draws keep
/// standard depth state in a reversed attachment.
pub fn dynamic_rendering_secondaries() -> Scene {
    let mut scene = secondary();
    scene.name = "dynamic-rendering-secondaries";
    scene.plan.passes[0].kind = PassKind::DynamicRendering;
    for step in &mut scene.plan.steps {
        if let Step::ExecuteSecondaries(_, recording) = step {
            *recording = Recording::ThreadPerSecondary;
        }
    }
    scene
}

/// `subpasses`: the overlap objects in one render pass with two subpasses sharing the depth
/// attachment: subpass 0 (no color attachment) is a depth-only pre-pass with LESS, subpass 1
/// draws the same objects in color with EQUAL (depth read-write layout, writes off); a
/// subpass dependency orders subpass 0's depth writes before subpass 1's tests. Subpass 1
/// draws farthest first, so that where two surfaces tie the pre-pass's choice wins: the image
/// is exactly the overlap image.
///
/// Layer item: compare ops and clear values in a multi-subpass render pass (the depth
/// attachment is reversed for both subpasses). A layer that handled only subpass 0, or only
/// single-subpass passes, leaves EQUAL comparing against unmatched values: nothing draws.
pub fn subpasses() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    b.pass(PassSpec {
        kind: PassKind::DepthPrepassSubpasses,
        ..PassSpec::clear(1.0)
    });
    let prepass = b.pipeline(PipelineSpec {
        program: Program::DepthOnly,
        color_write: false,
        ..PipelineSpec::standard("depth pre-pass", 0)
    });
    let color = b.pipeline(PipelineSpec {
        subpass: 1,
        ..test_only("equal", DepthTest::Static(Compare::Equal))
    });
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(prepass));
    b.draw(&objects);
    b.step(Step::NextSubpass);
    b.step(Step::Bind(color));
    // Farthest first: where surfaces tie exactly, the one the LESS pre-pass kept is drawn
    // last, so the image is exactly the overlap image.
    let reversed: Vec<usize> = objects.iter().rev().copied().collect();
    b.draw(&reversed);
    b.step(Step::EndPass);
    b.finish("subpasses", camera, None)
}

/// The objects of `dynamic-rendering`, nearest first: the overlap objects (drawn first) and
/// the two it draws after them (an orange cube and a pillar), each list's indices.
fn dynamic_rendering_objects(b: &mut Builder, camera: &Camera) -> (Vec<usize>, Vec<usize>) {
    let first = b.nearest_first(camera, overlap_objects());
    let second = b.nearest_first(
        camera,
        vec![
            grounded_cube("orange cube", 0.35, -0.2, 1.0, 0.7, rgb8(255, 140, 0)),
            Object::world(
                "pillar",
                Mesh::cuboid(DVec3::new(0.18, 1.4, 0.18)),
                DMat4::from_translation(DVec3::new(1.6, 1.35, -1.6)),
                rgb8(0, 230, 230),
            ),
        ],
    );
    (first, second)
}

/// `dynamic-rendering`: the overlap scene drawn with `vkCmdBeginRendering` (depth cleared to
/// 1.0 through `VkRenderingAttachmentInfo`, pipelines made with `VkPipelineRenderingCreateInfo`),
/// then a second `vkCmdBeginRendering` that loads color and depth and draws an orange cube
/// partly hidden by the near cube and a cyan pillar partly hidden by the slab.
///
/// Layer item: the clear value of dynamic rendering's attachment info. Unflipped, the first
/// rendering's reversed test passes nowhere: nothing draws in either rendering.
pub fn dynamic_rendering() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let (first, second) = dynamic_rendering_objects(&mut b, &camera);
    let dynamic = |depth, load_color| PassSpec {
        target: Target::Main,
        kind: PassKind::DynamicRendering,
        depth,
        load_color,
        multisample: None,
        view_mask: 0,
    };
    let clear = b.pass(dynamic(DepthLoad::Clear(1.0), false));
    let load = b.pass(dynamic(DepthLoad::Load, true));
    let standard = b.pipeline(PipelineSpec::standard("standard", clear));
    b.step(Step::BeginPass(clear));
    b.step(Step::Bind(standard));
    b.draw(&first);
    b.step(Step::EndPass);
    b.step(Step::BeginPass(load));
    b.step(Step::Bind(standard));
    b.draw(&second);
    b.step(Step::EndPass);
    b.finish("dynamic-rendering", camera, None)
}

/// `dynamic-rendering-suspended`: `dynamic-rendering`'s draws in one rendering (cleared to 1.0)
/// recorded as two render pass instances, as engines that split a rendering across recording
/// jobs do ([`PassKind::DynamicRenderingSuspended`]): the first begun with
/// `VK_RENDERING_SUSPENDING_BIT` draws the overlap objects, the second, begun with the same
/// info and `VK_RENDERING_RESUMING_BIT` right after the first ends, binds a pipeline of its own
/// and draws the rest. Its images are `dynamic-rendering`'s.
///
/// Layer item: the resumed instance loads and clears nothing (its load ops are the first
/// instance's, ignored), so a layer must not take it for a new rendering whose clear or
/// depth state starts again, nor record anything between the two instances (no action or
/// synchronization command may lie between them).
pub fn dynamic_rendering_suspended() -> Scene {
    suspended_built("dynamic-rendering-suspended", false)
}

/// `dynamic-rendering-suspended-across`: `dynamic-rendering-suspended` with the resumed
/// instance in a second primary command buffer, submitted right after the first in the same
/// batch: the first ends with the suspended instance, the second begins by resuming it (and
/// holds the rest of the frame), as a rendering split across recording jobs into command
/// buffers of their own is.
///
/// Layer item: the second command buffer knows the rendering only from its resuming begin
/// (no clear, no load), and its draws must get the reversed state all the same.
pub fn dynamic_rendering_suspended_across() -> Scene {
    suspended_built("dynamic-rendering-suspended-across", true)
}

fn suspended_built(name: &'static str, across_command_buffers: bool) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let (first, second) = dynamic_rendering_objects(&mut b, &camera);
    let pass = b.pass(PassSpec {
        target: Target::Main,
        kind: PassKind::DynamicRenderingSuspended {
            across_command_buffers,
        },
        depth: DepthLoad::Clear(1.0),
        load_color: false,
        multisample: None,
        view_mask: 0,
    });
    let standard = b.pipeline(PipelineSpec::standard("standard", pass));
    let resumed = b.pipeline(PipelineSpec {
        subpass: 1,
        ..PipelineSpec::standard("standard, resumed", pass)
    });
    b.step(Step::BeginPass(pass));
    b.step(Step::Bind(standard));
    b.draw(&first);
    b.step(Step::NextSubpass);
    b.step(Step::Bind(resumed));
    b.draw(&second);
    b.step(Step::EndPass);
    b.finish(name, camera, None)
}

/// The light of `shadow-map`: above the scene, behind it to the left, looking down at it
/// (shadows fall toward the camera and to the right).
pub fn shadow_light() -> Light {
    Light {
        eye: DVec3::new(-5.0, 10.0, -6.0),
        target: DVec3::new(0.0, 0.0, 0.0),
        up: DVec3::Y,
        half_extent: 8.0,
        perspective: false,
        near: 2.0,
        far: 25.0,
        map_format: crate::target::SHADOW_MAP_FORMAT,
    }
}

/// The light-space depth bias of the shadow pass (standard, positive: away from the light).
pub const SHADOW_BIAS: DepthBias = DepthBias {
    constant: 1.25,
    slope: 1.75,
    clamp: 0.0,
};

/// `shadow-map`: an orthographic shadow pass (light above, looking down) renders the cubes,
/// a pillar and the ground into a separate D32_SFLOAT shadow map (DEPTH_STENCIL_ATTACHMENT |
/// SAMPLED, cleared to 1.0, LESS, a standard positive depth bias), then the main pass (the
/// chosen depth format, perspective camera, LESS) draws the same objects with
/// `shadow_receiver.frag`, which samples the map through a comparison sampler
/// (`compareEnable`, LESS_OR_EQUAL) and darkens shadowed surfaces: long shadows fall on the
/// ground away from the light.
///
/// Layer item: depth images shaders sample. The shadow map is SAMPLED: revz reverses it (its
/// clear value, compare op, depth bias and viewport follow) and the receiver samples its read
/// twin, refreshed with standard depth at the end of the shadow pass (issue #39). A sampler
/// that read the reversed map would compare reversed stored depths against standard
/// references with LESS_OR_EQUAL and shadow everything (or nothing); a bias flipped wrong
/// brings back shadow acne (dark stripes on lit surfaces).
pub fn shadow_map() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let mut objects = overlap_objects();
    objects.retain(|o| o.name != "slab");
    objects.push(Object::world(
        "pillar",
        Mesh::cuboid(DVec3::new(0.15, 0.9, 0.15)),
        DMat4::from_translation(DVec3::new(-1.55, 0.85, 2.2)),
        rgb8(250, 210, 20),
    ));
    let objects = b.nearest_first(&camera, objects);
    let shadow = b.pass(PassSpec {
        target: Target::Shadow,
        ..PassSpec::clear(1.0)
    });
    let main = b.pass(PassSpec::clear(1.0));
    let caster = b.pipeline(PipelineSpec {
        program: Program::DepthOnly,
        color_write: false,
        bias: Bias::Static(SHADOW_BIAS),
        ..PipelineSpec::standard("shadow caster", shadow)
    });
    let receiver = b.pipeline(PipelineSpec {
        program: Program::ShadowReceiver,
        ..PipelineSpec::standard("shadow receiver", main)
    });
    for (pass, pipeline) in [(shadow, caster), (main, receiver)] {
        b.step(Step::BeginPass(pass));
        b.step(Step::Bind(pipeline));
        b.draw(&objects);
        b.step(Step::EndPass);
    }
    b.finish("shadow-map", camera, Some(shadow_light()))
}

/// `shadow-map-raw`: `shadow-map` whose receiver (`shadow_receiver_raw.frag`) reads the map's
/// raw depth values, with texel fetches of the four texels around the fragment and a sample
/// through a plain sampler (nearest, no comparison), and compares them with its light-space
/// depth itself. Its descriptor set is written through an update template (Vulkan 1.1 and up).
///
/// Layer item: shaders reading a depth image's values, not a comparison result (SSAO, fog,
/// soft particles, Hi-Z read their depth this way). The map is reversed and read through its
/// read twin (issue #39): every value the shader reads must be the standard one, or the manual
/// LESS_OR_EQUAL shadows nearly everything.
pub fn shadow_map_raw() -> Scene {
    let mut scene = shadow_map();
    scene.name = "shadow-map-raw";
    for pipeline in &mut scene.plan.pipelines {
        if pipeline.program == Program::ShadowReceiver {
            pipeline.program = Program::ShadowReceiverRaw;
        }
    }
    scene
}

/// `shadow-map-x8-d24`: `shadow-map` with an X8_D24_UNORM_PACK32 shadow map.
///
/// Layer item: a UNORM depth image that shaders sample. In `complementary` and `infinite` revz
/// stores it as D32_SFLOAT (promoted) and reversed, and its read twin is float32 too: the
/// receiver's comparisons see the standard values, at float resolution.
pub fn shadow_map_x8_d24() -> Scene {
    let mut scene = shadow_map();
    scene.name = "shadow-map-x8-d24";
    if let Some(light) = &mut scene.light {
        light.map_format = ash::vk::Format::X8_D24_UNORM_PACK32;
    }
    scene
}

/// `shadow-map-perspective`: `shadow-map` lit by a spot light, whose shadow pass projects in
/// perspective (near 2, far 25, the frustum 16 units across at the point looked at).
///
/// Layer item: a second perspective camera in the frame. The shadow casters take the precise
/// path with the light's projection, the main pass with the camera's: in `infinite` mode the
/// map stores the light's n / w, and its read twin must be refreshed with the light's n / f,
/// not the camera's (issue #39's "perspective light").
pub fn shadow_map_perspective() -> Scene {
    let mut scene = shadow_map();
    scene.name = "shadow-map-perspective";
    if let Some(light) = &mut scene.light {
        light.perspective = true;
    }
    scene
}

/// `shadow-map-secondaries`: `shadow-map` with each pass's draws recorded into two secondaries
/// on two threads, the second of each inheriting the render pass and subpass without the
/// framebuffer (which the inheritance info may leave null).
///
/// Layer item: a secondary without a framebuffer knows only its render pass and depth format,
/// and the sampled (native) shadow map and the reversed main attachment share D32: guessing by
/// format draws the shadow casters reversed into the native map, so no shadow lands. The render
/// must be `shadow-map`'s.
pub fn shadow_map_secondaries() -> Scene {
    in_secondaries(shadow_map(), "shadow-map-secondaries")
}

/// `shadow-map-perspective-secondaries`: `shadow-map-perspective` recorded as
/// `shadow-map-secondaries` is.
///
/// Layer item: in `infinite` mode the primary learns no camera of its own (its passes are
/// drawn from secondaries): the n / f the shadow map and the main view remember at the end
/// of their passes, which their next clears and the map's refresh use, is the one the
/// executed secondaries' draws used.
pub fn shadow_map_perspective_secondaries() -> Scene {
    in_secondaries(
        shadow_map_perspective(),
        "shadow-map-perspective-secondaries",
    )
}

/// `scene` (one of the shadow-map scenes: passes of a bind and draws) with each pass's draws
/// recorded into two secondaries on two threads, the second inheriting the render pass
/// without the framebuffer.
fn in_secondaries(mut scene: Scene, name: &'static str) -> Scene {
    scene.name = name;
    let mut steps = Vec::new();
    let mut lists: Vec<Vec<Step>> = Vec::new();
    for step in std::mem::take(&mut scene.plan.steps) {
        match step {
            Step::BeginPass(_) => steps.push(step),
            Step::Bind(_) => lists = vec![vec![step.clone()], vec![step]],
            Step::Draw(_) => {
                let shortest = if lists[0].len() <= lists[1].len() {
                    0
                } else {
                    1
                };
                lists[shortest].push(step);
            }
            Step::EndPass => {
                steps.push(Step::ExecuteSecondaries(
                    std::mem::take(&mut lists),
                    Recording::ThreadPerSecondaryOddWithoutFramebuffer,
                ));
                steps.push(step);
            }
            other => unreachable!("shadow-map records no {other:?}"),
        }
    }
    scene.plan.steps = steps;
    scene
}

/// The sample count of the multisampled scenes.
pub const MSAA_SAMPLES: u32 = 4;

/// `msaa-resolve`: the overlap scene (its objects, camera and drawing order) rendered at 4x
/// MSAA in a render pass made with `vkCreateRenderPass2`: one subpass draws into a transient
/// 4x color attachment and a transient 4x depth attachment (DEPTH_STENCIL_ATTACHMENT |
/// TRANSIENT_ATTACHMENT only: never read back, never copied), cleared to 1.0, LESS, pipelines
/// rasterizing 4 samples; at the end of the subpass the color is resolved
/// (`pResolveAttachments`) into the main color image and the depth through
/// `VkSubpassDescriptionDepthStencilResolve` into the main depth image (the one read back),
/// with `--depth-resolve`'s mode (default SAMPLE_ZERO; stencil NONE where the device allows
/// it, else the depth mode). The color image is the overlap image with antialiased edges.
///
/// Layer item: depth resolves of `vkCreateRenderPass2` render passes. The 4x image is not
/// observable, so the layer may reverse it; the read-back main image stays native by
/// default, and a reversed attachment resolved into a native one hands it reversed values
/// unless the layer keeps the 4x image native. Missed, the colors stay right but the depth
/// read back is 1 - D: `depth.png` shows the background (cleared to 1.0, resolved as 0) as
/// covered and the near cube dimmest. With both images reversed
/// (`reverse_observable = copies`), MIN and MAX must be swapped: unswapped, every
/// silhouette pixel of the depth image takes its farthest sample instead of its nearest (or
/// the reverse), so the depth silhouettes shrink (grow) by a pixel against the color image.
pub fn msaa_resolve() -> Scene {
    msaa_scene("msaa-resolve", PassKind::RenderPass)
}

/// `msaa-resolve-dynamic`: [`msaa_resolve`] with dynamic rendering: `vkCmdBeginRendering`
/// whose depth `VkRenderingAttachmentInfo` (and stencil one, for formats with stencil) names
/// the 4x depth view with `resolveMode` and the main depth image as `resolveImageView`, and
/// whose color attachment resolves (AVERAGE) into the main color image likewise.
///
/// Layer item: the resolve mode and resolve image of dynamic rendering's depth attachment
/// info. Missed, the same wrong depth image as [`msaa_resolve`]'s.
pub fn msaa_resolve_dynamic() -> Scene {
    msaa_scene("msaa-resolve-dynamic", PassKind::DynamicRendering)
}

/// The overlap scene (objects nearest first, one pass, the standard pipeline) with its pass
/// made a 4x multisampled one of `kind`, depth cleared to 1.0 and resolved with SAMPLE_ZERO
/// (`--depth-resolve` changes it).
fn msaa_scene(name: &'static str, kind: PassKind) -> Scene {
    let mut scene = overlap();
    scene.name = name;
    scene.plan.passes[0] = PassSpec {
        kind,
        multisample: Some(Multisample {
            samples: MSAA_SAMPLES,
            depth_resolve: ResolveMode::SampleZero,
            sampled_depth: false,
        }),
        ..PassSpec::clear(1.0)
    };
    scene
}

/// `depth-reads-msaa`: the overlap scene drawn twice, in this order:
/// - into the main color and depth images (single-sample, the standard pipeline, color writes
///   off): the depth the tester reads back (a multisampled image cannot be copied to a
///   buffer);
/// - at 4x MSAA in a `vkCreateRenderPass2` render pass, as `msaa-resolve` draws it, whose
///   color is resolved (AVERAGE) into the main color image, the image read back, but whose
///   depth attachment is kept: stored, not resolved, with SAMPLED usage (not transient);
///
/// then a barrier of the 4x depth image into `SHADER_READ_ONLY_OPTIMAL` and a post pass (the
/// main color loaded, no depth attachment) whose full-screen quad overwrites the bottom
/// quarter of the image (the ground, the cubes' feet and their silhouettes against it) with
/// a shade of the view distances of each pixel's four depth samples, read with
/// `texelFetch(sampler2DMS(..), pixel, s)` for each sample s ([`Program::DepthPostMs`],
/// `depth_post_ms.frag`): red from the nearest sample, green from the farthest, blue from
/// their spread (silhouette pixels, whose samples cover two surfaces). A barrier puts the 4x
/// depth back into its attachment layout. SSAO and edge detection on MSAA depth read it this
/// way, and so does OpenGL through Zink with multisampled depth textures.
///
/// Layer item: a multisampled depth image that shaders sample. Reversed, its read twin must
/// hold the standard value of every sample (a refresh per sample; a copy through a buffer
/// carries none), refreshed at the barrier into the shader's layout. Reversed values read as
/// they are shade the band as if everything lay at the near plane; a twin holding one
/// sample's value (or a resolve's) everywhere loses the silhouettes' spread.
pub fn depth_reads_msaa() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    let band = b.object(Object::full_screen("multisampled depth band", [1.0; 4]));
    let main = b.pass(PassSpec::clear(1.0));
    let multisampled = b.pass(PassSpec {
        multisample: Some(Multisample {
            samples: MSAA_SAMPLES,
            depth_resolve: ResolveMode::SampleZero,
            sampled_depth: true,
        }),
        ..PassSpec::clear(1.0)
    });
    let post = b.pass(PassSpec {
        target: Target::Post,
        depth: DepthLoad::Load,
        load_color: true,
        ..PassSpec::clear(1.0)
    });
    let read_back = b.pipeline(PipelineSpec {
        color_write: false,
        ..PipelineSpec::standard("flat, depth read back", main)
    });
    let flat = b.pipeline(PipelineSpec::standard("flat, 4x", multisampled));
    let shade = b.pipeline(PipelineSpec {
        program: Program::DepthPostMs,
        depth_test: DepthTest::Off,
        depth_write: false,
        ..PipelineSpec::standard("multisampled depth band", post)
    });
    b.step(Step::BeginPass(main));
    b.step(Step::Bind(read_back));
    b.draw(&objects);
    b.step(Step::EndPass);
    b.step(Step::BeginPass(multisampled));
    b.step(Step::Bind(flat));
    b.draw(&objects);
    b.step(Step::EndPass);
    b.step(Step::MultisampledDepthLayout {
        from: DepthLayout::Attachment,
        to: DepthLayout::Sampled,
    });
    b.step(Step::BeginPass(post));
    b.step(Step::Bind(shade));
    b.draw(&[band]);
    b.step(Step::EndPass);
    b.step(Step::MultisampledDepthLayout {
        from: DepthLayout::Sampled,
        to: DepthLayout::Attachment,
    });
    b.finish("depth-reads-msaa", camera, None)
}

/// A rectangle facing the eye of `camera` at view distance `distance` (so its depth is the same
/// at every pixel) that covers `[x0, x1] x [y0, y1]` of Vulkan NDC (y down) at aspect 1.
fn card(
    camera: &Camera,
    name: &'static str,
    distance: f64,
    [x0, y0, x1, y1]: [f64; 4],
    color: [f32; 4],
) -> Object {
    // NDC x = x_view / (t * distance), NDC y = -y_view / (t * distance).
    let scale = (camera.fov_y / 2.0).tan() * distance;
    Object::world(
        name,
        Mesh::rect_xy(
            scale * (x0 + x1) / 2.0,
            -scale * (y0 + y1) / 2.0,
            scale * (x1 - x0) / 2.0,
            scale * (y1 - y0) / 2.0,
        ),
        camera.view().inverse() * DMat4::from_translation(DVec3::new(0.0, 0.0, -distance)),
        color,
    )
}

/// `frag-depth`: three cards facing the eye (each at one depth), drawn in this order with LESS
/// and depth writes:
/// - a blue far wall (view distance 8, depth 0.98849; standard pipeline) on the left;
/// - a red card across the middle (distance 3, depth D = 0.96763), the nearest surface, drawn
///   with `frag_depth.frag` ([`Program::FragDepth`]): it stores 0.5 + 0.5 * D = 0.98382,
///   still in front of the wall (it covers the wall's upper right) and of the clear (1.0: its
///   upper band and its middle cover nothing else);
/// - a green card (distance 4.5, depth 0.97876; standard pipeline) on the right, geometrically
///   behind the red card but in front of its pushed-back depth: it passes against what the
///   red card stored and shows over the red card's lower right.
///
/// Layer item: fragment shaders that write `FragDepth` and read `gl_FragCoord.z`. Into a
/// reversed attachment the rewritten shader must read the standard depth (1 - z) and store the
/// reversal of what it computes (1 - x = 0.01618, between the green card's 1 - 0.97876 =
/// 0.02124 and the wall's 0.01151). Stores left unflipped (0.98382), or the reversed depth
/// read as it is (the shader computes 0.5 + 0.5 * 0.03237 = 0.51618, stored flipped as
/// 0.48382 or as it is), all land near the eye: the red card covers the green one where they
/// overlap. A FragDepth draw left with LESS fails against the reversed clear (0): the red card
/// vanishes, the wall and the background show through. Where the red card is alone, the depth
/// read back is the stored FragDepth value itself.
pub fn frag_depth() -> Scene {
    frag_depth_built("frag-depth", false)
}

/// `frag-depth-library` (needs `VK_EXT_graphics_pipeline_library`): [`frag_depth`] with every
/// pipeline built from four libraries linked together, as in [`pipeline_library`].
///
/// Layer item: a fragment shader library that computes with depth. The layer must give the
/// fragment shader library a variant with the rewritten shader and bind, for draws into a
/// reversed attachment, a variant of the linked pipeline that links it; a layer that links
/// the application's library shows what [`frag_depth`] shows with the shader untouched.
pub fn frag_depth_library() -> Scene {
    frag_depth_built("frag-depth-library", true)
}

/// `frag-depth-library-dynamic`: `frag-depth-library` in a dynamic rendering (its libraries
/// chain `VkPipelineRenderingCreateInfo`, the formats in the fragment output interface alone):
/// the fragment shader library that writes `FragDepth` is rewritten without a render pass.
pub fn frag_depth_library_dynamic() -> Scene {
    let mut scene = frag_depth_built("frag-depth-library-dynamic", true);
    for pass in &mut scene.plan.passes {
        pass.kind = PassKind::DynamicRendering;
    }
    scene
}

/// The `frag-depth` scene named `name`, its pipelines built from libraries or not.
fn frag_depth_built(name: &'static str, libraries: bool) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let wall = b.object(card(
        &camera,
        "far wall",
        8.0,
        [-0.85, -0.2, -0.15, 0.7],
        rgb8(40, 80, 240),
    ));
    let pushed = b.object(card(
        &camera,
        "pushed card",
        3.0,
        [-0.5, -0.6, 0.5, 0.3],
        rgb8(230, 30, 30),
    ));
    let middle = b.object(card(
        &camera,
        "middle card",
        4.5,
        [0.15, -0.2, 0.85, 0.7],
        rgb8(30, 200, 40),
    ));
    b.pass(PassSpec::clear(1.0));
    let standard = b.pipeline(PipelineSpec {
        libraries,
        ..PipelineSpec::standard("standard", 0)
    });
    let frag_depth = b.pipeline(PipelineSpec {
        program: Program::FragDepth,
        libraries,
        ..PipelineSpec::standard("frag depth", 0)
    });
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.step(Step::Draw(wall));
    b.step(Step::Bind(frag_depth));
    b.step(Step::Draw(pushed));
    b.step(Step::Bind(standard));
    b.step(Step::Draw(middle));
    b.step(Step::EndPass);
    b.finish(name, camera, None)
}

/// A rectangle `[x ± half_width] x [y ± half_height]` on the +z face of `cube` (a
/// [`grounded_cube`] of half size `half`): the face's plane in the cube's own model space
/// (local z = `half`, the very f32 value of the face's vertices) with the cube's model matrix,
/// so exactly coplanar with the face.
fn face_decal(
    name: &'static str,
    cube: &Object,
    half: f64,
    [x, y, half_width, half_height]: [f64; 4],
    color: [f32; 4],
) -> Object {
    Object {
        name,
        mesh: Mesh::rect_xy(x, y, half_width, half_height).translated(DVec3::new(0.0, 0.0, half)),
        color,
        ..cube.clone()
    }
}

/// The half sizes of the overlap scene's near and middle cubes (see `overlap_objects`).
pub(super) const NEAR_CUBE_HALF: f64 = 0.5;
/// See [`NEAR_CUBE_HALF`].
pub(super) const MIDDLE_CUBE_HALF: f64 = 0.75;

/// `pipeline-library-dynamic`: `pipeline-library` in a dynamic rendering, as DXVK draws: its
/// libraries chain the rendering's `VkPipelineRenderingCreateInfo` (the view mask for the
/// shader libraries, the attachment formats for the fragment output interface) instead of a
/// render pass.
///
/// Layer item: the formats a promoted attachment's pipelines must name are in the fragment
/// output interface library alone, the compare op and bias in the fragment shader and
/// pre-rasterization libraries, and the link names none of them.
pub fn pipeline_library_dynamic() -> Scene {
    let mut scene = pipeline_library();
    scene.name = "pipeline-library-dynamic";
    for pass in &mut scene.plan.passes {
        pass.kind = PassKind::DynamicRendering;
    }
    scene
}

/// `pipeline-library` (needs `VK_EXT_graphics_pipeline_library`): every pipeline is built
/// from four libraries (vertex input interface, pre-rasterization shaders, fragment shader,
/// fragment output interface; each given the render pass and subpass where it needs them)
/// linked into the pipeline bound, with all depth state static and where the extension puts
/// it: the viewport and the rasterization state (depth bias) in the pre-rasterization
/// library, the depth-stencil state (compare op, test and write) in the fragment shader
/// library. One render pass (depth cleared to 1.0) draws:
/// - the overlap objects with LESS and depth writes (the nearest wins: the red cube in front
///   of the green one, the slab cutting the green cube, the blue cube behind);
/// - two decals coplanar with the +z faces of the red and green cubes (same model matrix,
///   the face's own plane), with LESS, no depth writes and the static bias of `depth-bias`
///   (constant -8, slope -12, clamp -1e-4 when the device has `depthBiasClamp`): a white
///   square on the red cube, a cyan band on the green cube whose left end passes behind the
///   red cube, which hides it there (the red cube is in front by far more than the bias);
/// - a full-screen sky quad (clip depth 0.5) with viewport depth range [1, 1] and
///   LESS_OR_EQUAL without depth writes: it fills the background above the ground only.
///
/// Layer item: depth state carried by pipeline libraries. The layer must change the libraries
/// as it changes ordinary pipelines (swap the compare ops in the fragment shader library;
/// negate the bias and flip the viewport depth range in the pre-rasterization library, as its
/// mode wants): the linked create info carries no depth state at all. A layer that passes
/// library pipelines through untouched into a reversed depth buffer (cleared to 0) leaves
/// LESS and LESS_OR_EQUAL failing against it at every pixel: the whole image is the clear
/// color. With the fragment shader library handled but not the pre-rasterization one: the
/// unflipped [1, 1] sky lands at reversed depth 1, the nearest, and covers the whole image;
/// an unnegated bias pushes the decals behind their faces (they vanish: plain red and green
/// faces, the white square and cyan band gone); on the flip path (viewport flipped for a
/// standard projection) a missed flip also leaves standard depths tested with GREATER, so the
/// farthest surface wins (the ground over the cubes).
pub fn pipeline_library() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = overlap_objects();
    let cube = |name: &str| {
        objects
            .iter()
            .find(|o| o.name == name)
            .expect("overlap has the cube")
            .clone()
    };
    let (near, middle) = (cube("near cube"), cube("middle cube"));
    let world = b.nearest_first(&camera, objects);
    let decals = [
        face_decal(
            "near cube decal",
            &near,
            NEAR_CUBE_HALF,
            [0.0, 0.05, 0.25, 0.25],
            rgb8(240, 240, 240),
        ),
        face_decal(
            "middle cube decal",
            &middle,
            MIDDLE_CUBE_HALF,
            [-0.1, 0.25, 0.55, 0.15],
            rgb8(0, 230, 230),
        ),
    ]
    .map(|o| b.object(o));
    let sky = b.object(Object::full_screen("sky", rgb8(120, 180, 240)));
    b.pass(PassSpec::clear(1.0));
    let library = |spec: PipelineSpec| PipelineSpec {
        libraries: true,
        ..spec
    };
    let standard = b.pipeline(library(PipelineSpec::standard("standard", 0)));
    let decal = b.pipeline(library(PipelineSpec {
        bias: Bias::Static(DECAL_BIAS),
        ..test_only("decal", DepthTest::Static(Compare::Less))
    }));
    let sky_pipeline = b.pipeline(library(PipelineSpec {
        viewport: Viewport::Static {
            min_depth: 1.0,
            max_depth: 1.0,
        },
        ..test_only("sky", DepthTest::Static(Compare::LessOrEqual))
    }));
    b.step(Step::BeginPass(0));
    b.step(Step::Bind(standard));
    b.draw(&world);
    b.step(Step::Bind(decal));
    b.draw(&decals);
    b.step(Step::Bind(sky_pipeline));
    b.step(Step::Draw(sky));
    b.step(Step::EndPass);
    b.finish("pipeline-library", camera, None)
}

/// `depth-reads`: the overlap scene, then two passes that read its depth as engines do.
/// First soft particles: three camera-facing quads (smoke in front of the near cube, mist
/// through the middle one, haze before the far one), drawn in a pass that attaches the main
/// depth read-only (the render pass moves it from the attachment layout into
/// `DEPTH_STENCIL_READ_ONLY_OPTIMAL` and leaves it there) with LESS and no writes, while their
/// fragment shader fetches the same depth to fade each particle where the scene lies close
/// behind it. Then a barrier into `SHADER_READ_ONLY_OPTIMAL`, a compute pass that builds a
/// depth pyramid level from it (each 4 x 4 tile's nearest and farthest depth, as Hi-Z
/// occlusion culling does), and a post pass of full-screen quads (color only) that overwrite
/// the bottom quarter of the image with a shade of the depth's view distance, read with a
/// texel fetch, a bilinear sample and a gather side by side, and the top quarter with a shade
/// of the tiles. A barrier puts the depth back into its attachment layout for the read-back.
///
/// Layer item (issue #39): a depth image that shaders read after the pass that writes it is
/// reversed, and its read twin holds the standard values whenever they read: refreshed before
/// the soft particles' pass begins (its implicit transition makes the image readable inside
/// the pass, where no refresh can be recorded), and not again at the barrier into the post
/// pass's layout (nothing wrote the image while it was read-only). Reversed values would fade
/// every particle and shade the band wrong; a stale twin (the previous frame's) would too.
pub fn depth_reads() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    let particle = |name, x, y, z, half_width, half_height, color| {
        Object::world(
            name,
            Mesh::rect_xy(x, y, half_width, half_height),
            DMat4::from_translation(DVec3::new(0.0, 0.0, z)),
            color,
        )
    };
    let particles = b.nearest_first(
        &camera,
        vec![
            particle("smoke", -0.75, 0.4, 2.2, 0.9, 0.5, rgb8(225, 225, 235)),
            particle("mist", 0.35, 0.6, 0.5, 1.2, 0.7, rgb8(200, 230, 255)),
            particle("haze", -0.55, 1.0, -3.0, 1.6, 1.0, rgb8(255, 220, 180)),
        ],
    );
    let band = b.object(Object::full_screen("depth band", [1.0; 4]));
    let main = b.pass(PassSpec::clear(1.0));
    let loaded = |target| PassSpec {
        target,
        depth: DepthLoad::Load,
        load_color: true,
        ..PassSpec::clear(1.0)
    };
    let soft = b.pass(loaded(Target::SoftParticles));
    let post = b.pass(loaded(Target::Post));
    let flat = b.pipeline(PipelineSpec::standard("flat", main));
    let particles_pipeline = b.pipeline(PipelineSpec {
        program: Program::SoftParticle,
        depth_write: false,
        ..PipelineSpec::standard("soft particles", soft)
    });
    let shade = b.pipeline(PipelineSpec {
        program: Program::DepthPost,
        depth_test: DepthTest::Off,
        depth_write: false,
        ..PipelineSpec::standard("depth band", post)
    });
    let tiles = b.pipeline(PipelineSpec {
        program: Program::DepthTiles,
        depth_test: DepthTest::Off,
        depth_write: false,
        ..PipelineSpec::standard("depth tiles band", post)
    });
    b.step(Step::BeginPass(main));
    b.step(Step::Bind(flat));
    b.draw(&objects);
    b.step(Step::EndPass);
    b.step(Step::BeginPass(soft));
    b.step(Step::Bind(particles_pipeline));
    b.draw(&particles);
    b.step(Step::EndPass);
    b.step(Step::MainDepthLayout {
        from: DepthLayout::ReadOnly,
        to: DepthLayout::Sampled,
    });
    b.step(Step::BuildDepthTiles);
    b.step(Step::BeginPass(post));
    b.step(Step::Bind(shade));
    b.draw(&[band]);
    b.step(Step::Bind(tiles));
    b.draw(&[band]);
    b.step(Step::EndPass);
    b.step(Step::MainDepthLayout {
        from: DepthLayout::Sampled,
        to: DepthLayout::Attachment,
    });
    b.finish("depth-reads", camera, None)
}

/// `stencil-reads`: the overlap scene drawn with stencil writes (the ground marks 2, every
/// other object 1, where it passes the depth test), then a barrier into
/// `SHADER_READ_ONLY_OPTIMAL` and a post pass that overwrites a band across the middle of the
/// image (cubes, ground and background) with a shade of the stencil value and the depth's view distance, each read with a texel
/// fetch of its own aspect's view. Depth formats with stencil only.
///
/// Layer item (issue #39): the stencil aspect of a reversed depth-stencil image that shaders
/// sample. Its read twin holds the stencil as it is and the depth converted: on lavapipe a
/// stencil-only image copy writes the depth too, so the refresh must copy the stencil first.
pub fn stencil_reads() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let (ground, others): (Vec<Object>, Vec<Object>) = overlap_objects()
        .into_iter()
        .partition(|o| o.name == "ground");
    let others = b.nearest_first(&camera, others);
    let ground = b.nearest_first(&camera, ground);
    let band = b.object(Object::full_screen("stencil band", [1.0; 4]));
    let main = b.pass(PassSpec::clear(1.0));
    let post = b.pass(PassSpec {
        target: Target::Post,
        depth: DepthLoad::Load,
        load_color: true,
        ..PassSpec::clear(1.0)
    });
    let marking = |name, reference| PipelineSpec {
        stencil: Some(StencilTest {
            compare: Compare::Always,
            reference,
            on_pass: StencilWrite::Replace,
        }),
        ..PipelineSpec::standard(name, main)
    };
    let objects_pipeline = b.pipeline(marking("objects, stencil 1", 1));
    let ground_pipeline = b.pipeline(marking("ground, stencil 2", 2));
    let shade = b.pipeline(PipelineSpec {
        program: Program::StencilPost,
        depth_test: DepthTest::Off,
        depth_write: false,
        ..PipelineSpec::standard("stencil band", post)
    });
    b.step(Step::BeginPass(main));
    b.step(Step::Bind(objects_pipeline));
    b.draw(&others);
    b.step(Step::Bind(ground_pipeline));
    b.draw(&ground);
    b.step(Step::EndPass);
    b.step(Step::MainDepthLayout {
        from: DepthLayout::Attachment,
        to: DepthLayout::Sampled,
    });
    b.step(Step::BeginPass(post));
    b.step(Step::Bind(shade));
    b.draw(&[band]);
    b.step(Step::EndPass);
    b.step(Step::MainDepthLayout {
        from: DepthLayout::Sampled,
        to: DepthLayout::Attachment,
    });
    b.finish("stencil-reads", camera, None)
}

/// A band of the deferred-depth scenes: a clip-space quad over a quarter of the image's
/// height (clip y in [center - 0.25, center + 0.25], Vulkan's y down) at clip depth 0.5.
fn quarter_band(name: &'static str, center: f64) -> Object {
    Object {
        model: DMat4::from_translation(DVec3::new(0.0, center, 0.0))
            * DMat4::from_scale(DVec3::new(1.0, 0.25, 1.0)),
        ..Object::full_screen(name, [1.0; 4])
    }
}

/// The overlap scene in subpass 0 of a [`PassKind::DepthInputSubpasses`] render pass, then in
/// subpass 1 `band` drawn with [`Program::DepthInput`] (the depth read as an input attachment),
/// `depth_test` (the depth attached read-only where it is not `Off`) and `viewport`.
fn deferred_depth_scene(
    name: &'static str,
    band: Object,
    (depth_test, viewport): (DepthTest, Viewport),
    libraries: bool,
) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    let band = b.object(band);
    let pass = b.pass(PassSpec {
        kind: PassKind::DepthInputSubpasses {
            depth_attached: depth_test != DepthTest::Off,
        },
        ..PassSpec::clear(1.0)
    });
    let flat = b.pipeline(PipelineSpec {
        libraries,
        ..PipelineSpec::standard("flat", pass)
    });
    let shade = b.pipeline(PipelineSpec {
        subpass: 1,
        program: Program::DepthInput,
        depth_test,
        depth_write: false,
        viewport,
        libraries,
        ..PipelineSpec::standard("depth input band", pass)
    });
    b.step(Step::BeginPass(pass));
    b.step(Step::Bind(flat));
    b.draw(&objects);
    b.step(Step::NextSubpass);
    b.step(Step::Bind(shade));
    b.draw(&[band]);
    b.step(Step::EndPass);
    b.finish(name, camera, None)
}

/// `deferred-depth`: the overlap scene drawn in subpass 0 of a render pass, then subpass 1 of
/// the same pass reads its depth as an input attachment, as deferred renderers do (a
/// `subpassLoad` in the fragment shader, the attachment in `DEPTH_STENCIL_READ_ONLY_OPTIMAL`,
/// its depth aspect named with `VkRenderPassInputAttachmentAspectCreateInfo`, the descriptor
/// written with `vkUpdateDescriptorSets`): subpass 1 has no depth attachment, only the color
/// and the input attachment, and a quad over the bottom quarter of the image (the ground; no
/// depth test) shades it with the depth's view distance, as `depth-reads`' post pass does.
///
/// Layer item: depth read as an input attachment in the render pass that writes it, where no
/// read twin can be refreshed. Reversed values read as they are would shade the band wrong
/// (view distances near the near plane instead of the scene's).
pub fn deferred_depth() -> Scene {
    deferred_depth_scene(
        "deferred-depth",
        quarter_band("depth input band", 0.75),
        (DepthTest::Off, Viewport::FULL),
        false,
    )
}

/// `deferred-depth-secondaries`: [`deferred_depth`] with subpass 0's draws recorded into two
/// secondary command buffers on two threads, the second inheriting the render pass and
/// subpass without the framebuffer (which the inheritance info may leave null); subpass 1
/// inline.
///
/// Layer item: in `infinite` mode an image read as an input attachment stores complementary
/// depth, which a secondary must know to draw into it; without its framebuffer, only the
/// render pass tells (it reads that depth attachment as an input, so its image has the
/// usage). A secondary that assumed `n / w` would store its objects in another convention
/// than the other's: the depth test between them and the band's shading go wrong.
pub fn deferred_depth_secondaries() -> Scene {
    let mut scene = deferred_depth();
    scene.name = "deferred-depth-secondaries";
    let mut steps = Vec::new();
    let mut bind = None;
    let mut draws = Vec::new();
    let mut geometry = true;
    for step in std::mem::take(&mut scene.plan.steps) {
        match step {
            Step::Bind(_) if geometry => bind = Some(step),
            Step::Draw(_) if geometry => draws.push(step),
            Step::NextSubpass if geometry => {
                geometry = false;
                // The first half of the draws, then the second: executed in order, the
                // objects are drawn in the order the inline scene draws them (nearest
                // first), so that depth ties resolve alike.
                let bind = bind.take().expect("subpass 0 binds its pipeline");
                let second = draws.split_off(draws.len().div_ceil(2));
                let lists = [std::mem::take(&mut draws), second]
                    .into_iter()
                    .map(|half| std::iter::once(bind.clone()).chain(half).collect())
                    .collect();
                steps.push(Step::ExecuteSecondaries(
                    lists,
                    Recording::ThreadPerSecondaryOddWithoutFramebuffer,
                ));
                steps.push(step);
            }
            other => steps.push(other),
        }
    }
    scene.plan.steps = steps;
    scene
}

/// `deferred-depth-library` (needs `VK_EXT_graphics_pipeline_library`): [`deferred_depth`]
/// with every pipeline built from four libraries linked together, as in [`pipeline_library`].
///
/// Layer item: a fragment shader library reading depth through an input attachment. The
/// layer must give that library a variant converting the reads and link it into a variant of
/// the linked pipeline, bound where the subpass reads reversed depth; a layer that links the
/// application's library shades the band with reversed values.
pub fn deferred_depth_library() -> Scene {
    deferred_depth_scene(
        "deferred-depth-library",
        quarter_band("depth input band", 0.75),
        (DepthTest::Off, Viewport::FULL),
        true,
    )
}

/// The deferred-depth scene `scene` (one [`PassKind::DepthInputSubpasses`] render pass) named
/// `name`, rendered in one [`PassKind::DynamicRenderingLocalRead`] rendering instead: the same
/// objects, pipelines and steps, its subpass 1 the draws after the rendering's by-region
/// barrier, its band's program the one the rendering maps the depth to (the decorated
/// `depth_input.frag` where `indexed`, its undecorated twin otherwise). The images are the
/// render pass scene's.
fn in_local_read(mut scene: Scene, name: &'static str, indexed: bool) -> Scene {
    scene.name = name;
    let kind = PassKind::DynamicRenderingLocalRead { indexed };
    for pass in &mut scene.plan.passes {
        assert!(
            pass.kind.reads_depth_input(),
            "{name}: a deferred-depth scene"
        );
        pass.kind = kind;
    }
    for pipeline in &mut scene.plan.pipelines {
        if pipeline.program.reads_depth_input() {
            pipeline.program = kind
                .depth_input_program()
                .expect("a local-read rendering reads an input attachment");
        }
    }
    scene
}

/// `deferred-depth-local-read` (needs `VK_KHR_dynamic_rendering_local_read`, core in Vulkan
/// 1.4: lavapipe from Mesa 25.0, not 22.3): [`deferred_depth`] in one `vkCmdBeginRendering`
/// (color cleared, depth cleared to 1.0 and kept attached throughout, the main depth image in
/// `VK_IMAGE_LAYOUT_RENDERING_LOCAL_READ_KHR` for the whole rendering: a barrier into it before
/// `vkCmdBeginRendering`, one back into its attachment layout after `vkCmdEndRendering`). The
/// overlap objects are drawn as in `deferred-depth`; then, inside the same rendering, a
/// `vkCmdPipelineBarrier` with `VK_DEPENDENCY_BY_REGION_BIT` (a memory barrier from the depth
/// and color attachment writes to input attachment reads, depth tests and color writes) and
/// the band over the bottom quarter, with depth test and writes off (its
/// `VkPipelineRenderingCreateInfo` still names the depth format), whose fragment shader reads
/// the depth with `subpassLoad` from an input attachment variable without an
/// `InputAttachmentIndex` decoration (`depth_input_undecorated.frag`): with no
/// `VkRenderingInputAttachmentIndexInfo` in the pipeline and none set on the command buffer,
/// the depth attachment maps to exactly that variable. The descriptor (INPUT_ATTACHMENT)
/// names the main depth's depth-aspect view in `RENDERING_LOCAL_READ_KHR`. The image is
/// `deferred-depth`'s.
///
/// Layer item: depth read as an input attachment inside the dynamic rendering that writes it,
/// where, as in a render pass, no read twin can be refreshed: the shader's reads must be
/// converted, and the variable to convert is found through the rendering's mapping (here the
/// default one: the undecorated input attachment). Reversed values read as they are shade the
/// band wrong (view distances near the near plane instead of the scene's).
pub fn deferred_depth_local_read() -> Scene {
    in_local_read(deferred_depth(), "deferred-depth-local-read", false)
}

/// `deferred-depth-local-read-indexed` (needs `VK_KHR_dynamic_rendering_local_read`):
/// [`deferred_depth_local_read`] with the depth mapped to input attachment index 0
/// explicitly: every pipeline of the rendering chains `VkRenderingInputAttachmentIndexInfoKHR`
/// (`pDepthInputAttachmentIndex` pointing to 0, the color attachment mapped to
/// `VK_ATTACHMENT_UNUSED` through `pColorAttachmentInputIndices`), the command buffer sets the
/// same mapping with `vkCmdSetRenderingInputAttachmentIndicesKHR` right after
/// `vkCmdBeginRendering` (the two must match at each draw; until it is called the default
/// mapping applies), and the band's shader is `deferred-depth`'s own `depth_input.frag`
/// (`input_attachment_index = 0`). The image is `deferred-depth`'s.
///
/// Layer item: as `deferred-depth-local-read`, the depth's variable found through an explicit
/// mapping, set in the pipeline and on the command buffer: the one decorated with index 0. A
/// layer that converted only the undecorated variable (the default mapping's) would leave
/// this band's reads reversed.
pub fn deferred_depth_local_read_indexed() -> Scene {
    in_local_read(deferred_depth(), "deferred-depth-local-read-indexed", true)
}

/// `deferred-depth-local-read-tested` (needs `VK_KHR_dynamic_rendering_local_read`):
/// [`deferred_depth_tested`] in one local-read rendering, as [`deferred_depth_local_read`]
/// renders `deferred-depth`: the band over the top quarter drawn at depth
/// [`DEFERRED_BAND_DEPTH`] (a static viewport depth range [d, d]) with GREATER against the
/// depth attachment (no writes) while its shader reads the same depth through the undecorated
/// input attachment, the attachment in `RENDERING_LOCAL_READ_KHR` (not a read-only layout) the
/// whole time. The image is `deferred-depth-tested`'s.
///
/// Layer item: as `deferred-depth-local-read`, and a depth test against the attachment the
/// shader reads at once: the band's fixed depth and its compare op reversed with the
/// attachment (left standard, the band would shade the background and leave the surfaces).
pub fn deferred_depth_local_read_tested() -> Scene {
    in_local_read(
        deferred_depth_tested(),
        "deferred-depth-local-read-tested",
        false,
    )
}

/// The depth of `deferred-depth-tested`'s band (its viewport's depth range, [d, d]): behind every surface of the overlap
/// scene (the far end of the ground lies at depth 0.996) and in front of the cleared
/// background (1.0), with margins far above every format's resolution (checked in the unit
/// tests), so that the test never ties.
pub const DEFERRED_BAND_DEPTH: f64 = 0.999;

/// `deferred-depth-tested`: `deferred-depth` with the depth also attached read-only in
/// subpass 1 (the same attachment as the input attachment, both in
/// `DEPTH_STENCIL_READ_ONLY_OPTIMAL`) and the band over the top quarter of the image (the far
/// cube, the slab, the middle cube's top, the far ground and the background) drawn at depth
/// [`DEFERRED_BAND_DEPTH`] (a static viewport depth range [d, d], as skies are drawn) with
/// GREATER (no writes): the surfaces in front of the band are shaded with their view
/// distance, the background is left as it is.
///
/// Layer item: as `deferred-depth`, and a depth test against the attachment the shader reads
/// at once: the band's fixed depth and its compare op reversed with the attachment (left
/// standard, the band would shade the background and leave the surfaces).
pub fn deferred_depth_tested() -> Scene {
    deferred_depth_tested_built("deferred-depth-tested", false)
}

/// `deferred-depth-tested-library` (needs `VK_EXT_graphics_pipeline_library`):
/// [`deferred_depth_tested`] with every pipeline built from libraries linked together: the
/// band's pipeline links a fragment shader library that reads the depth and tests against it
/// at once (its reversed variant converts the reads and flips the compare op).
pub fn deferred_depth_tested_library() -> Scene {
    deferred_depth_tested_built("deferred-depth-tested-library", true)
}

fn deferred_depth_tested_built(name: &'static str, libraries: bool) -> Scene {
    deferred_depth_scene(
        name,
        quarter_band("tested depth input band", -0.75),
        (
            DepthTest::Static(Compare::Greater),
            Viewport::Static {
                min_depth: DEFERRED_BAND_DEPTH as f32,
                max_depth: DEFERRED_BAND_DEPTH as f32,
            },
        ),
        libraries,
    )
}

/// The mip levels of `depth-mips`' depth image (256 x 256, 128 x 128, 64 x 64 at the
/// tester's usual size).
pub const DEPTH_MIP_LEVELS: u32 = 3;

/// `depth-mips`: the overlap scene rendered into mip level 0 of a depth image of
/// [`DEPTH_MIP_LEVELS`] levels, whose lower levels the application then fills the way engines
/// fill a depth chain without a shader: per level N, level N - 1 into `TRANSFER_SRC_OPTIMAL`,
/// level N (its contents discarded) into `TRANSFER_DST_OPTIMAL`, a `vkCmdBlitImage` of level
/// N - 1 into level N (NEAREST, as depth blits must be: one texel of each 2 x 2 block), then
/// a barrier of level N - 1 alone into `SHADER_READ_ONLY_OPTIMAL`; the last level goes there
/// last, by a barrier of its own. Then a post pass overwrites the bottom quarter of the image
/// with a shade of level 1's view distance and the top quarter with level 2's
/// ([`Program::DepthMipsPost`], texel fetches through a view of the whole chain, written with
/// `vkUpdateDescriptorSets`), and a barrier of the whole chain puts it back into its
/// attachment layout for the read-back (of level 0).
///
/// (A fragment shader that builds each level, writing `gl_FragDepth` from texel fetches of a
/// view of the level below while a view of its own level is the depth attachment, is how
/// engines build a depth pyramid too; lavapipe 22.3 crashes on it: any draw whose fragment
/// shader reads one level of the image whose other level is the pass's depth attachment
/// faults in its rasterizer thread, natively.)
///
/// Layer item (issue #39): a reversed depth image of several mip levels read through its
/// twin, refreshed level by level (each barrier's level alone, after that level was written:
/// level 0 by the render pass, levels 1 and 2 by a blit), and blits between the levels of a
/// reversed image, which must copy reversed values as they are. A refresh of the wrong level,
/// or of level 0 alone, leaves a band shading stale or unwritten depth; reversed values read
/// shade both bands wrong.
pub fn depth_mips() -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    let band = b.object(Object::full_screen("depth mips band", [1.0; 4]));
    let main = b.pass(PassSpec::clear(1.0));
    let post = b.pass(PassSpec {
        target: Target::Post,
        depth: DepthLoad::Load,
        load_color: true,
        ..PassSpec::clear(1.0)
    });
    let flat = b.pipeline(PipelineSpec::standard("flat", main));
    let shade = b.pipeline(PipelineSpec {
        program: Program::DepthMipsPost,
        depth_test: DepthTest::Off,
        depth_write: false,
        ..PipelineSpec::standard("depth mips bands", post)
    });
    b.step(Step::BeginPass(main));
    b.step(Step::Bind(flat));
    b.draw(&objects);
    b.step(Step::EndPass);
    let barrier = |level, from, to| Step::DepthLevelLayout { level, from, to };
    b.step(barrier(
        0,
        DepthLayout::Attachment,
        DepthLayout::TransferSrc,
    ));
    for level in 1..DEPTH_MIP_LEVELS {
        b.step(barrier(
            level,
            DepthLayout::Undefined,
            DepthLayout::TransferDst,
        ));
        b.step(Step::BlitDepthLevel { level });
        b.step(barrier(
            level - 1,
            DepthLayout::TransferSrc,
            DepthLayout::Sampled,
        ));
        let next = if level + 1 < DEPTH_MIP_LEVELS {
            DepthLayout::TransferSrc
        } else {
            DepthLayout::Sampled
        };
        b.step(barrier(level, DepthLayout::TransferDst, next));
    }
    b.step(Step::BeginPass(post));
    b.step(Step::Bind(shade));
    b.step(Step::Draw(band));
    b.step(Step::EndPass);
    b.step(Step::MainDepthLayout {
        from: DepthLayout::Sampled,
        to: DepthLayout::Attachment,
    });
    b.finish("depth-mips", camera, None)
}

/// Where `depth-layers` moves the near cube in its layer 1: to the right of the middle cube's
/// front (x 1.1 instead of -0.75), at the same distance.
pub const MOVED_NEAR_CUBE_X: f64 = 1.1;

/// `depth-layers`: a depth image of two array layers (a 2D array, as a cascaded shadow map or
/// the two views of a stereo renderer are): the overlap scene rendered into layer 0 (the main
/// pass, with color), then the same scene with the near cube moved to the right
/// ([`MOVED_NEAR_CUBE_X`]) into layer 1 by a depth-only render pass (cleared, LESS), each
/// through a view of its layer alone as the pass's depth attachment. Then a barrier of the
/// whole image (both layers) into `SHADER_READ_ONLY_OPTIMAL` and a post pass that overwrites
/// the bottom quarter of the image with a shade of layer 0's view distance and the quarter
/// above it with layer 1's ([`Program::DepthLayersPost`], texel fetches through a 2D-array
/// view of both layers, written with `vkUpdateDescriptorSets`): the near cube shows on the
/// left in the first band's rows, on the right in the second's. A barrier of both layers puts
/// the image back into its attachment layout for the read-back (of layer 0).
///
/// Layer item (issue #39): a reversed layered depth image read through its twin, whose
/// refresh must convert every layer the barrier names (layer 1 was written by a pass of its
/// own, with no color): a twin refreshed for layer 0 alone shades the second band from a stale
/// or unwritten layer; reversed values shade both bands wrong.
pub fn depth_layers() -> Scene {
    depth_layers_built("depth-layers", false)
}

/// `depth-layers-stepwise`: [`depth_layers`], with layer 1 first rendered as layer 0 is (the
/// near cube in place) and both layers made readable (a barrier of the whole image into
/// `SHADER_READ_ONLY_OPTIMAL`) and back before the main pass's layer 0 result stands and layer
/// 1 is rendered again with the near cube moved; the second barrier of both layers makes them
/// readable for the post pass, as before.
///
/// Layer item (issue #39, refresh only what was written): the second refresh needs layer 1
/// alone (layer 0 was refreshed by the first barrier and not written since: the main pass
/// writes it before the first barrier). A layer that skips layer 1 there shades the second
/// band from the first render (the near cube in place); one that refreshes both layers again
/// is correct, at twice the cost.
pub fn depth_layers_stepwise() -> Scene {
    depth_layers_built("depth-layers-stepwise", true)
}

fn depth_layers_built(name: &'static str, stepwise: bool) -> Scene {
    let camera = overlap_camera();
    let mut b = Builder::default();
    let objects = b.nearest_first(&camera, overlap_objects());
    let moved = b.object(grounded_cube(
        "moved near cube",
        NEAR_CUBE_HALF,
        MOVED_NEAR_CUBE_X,
        1.9,
        0.35,
        rgb8(230, 30, 30),
    ));
    let mut second: Vec<usize> = objects
        .iter()
        .copied()
        .filter(|&n| b.objects[n].name != "near cube")
        .collect();
    second.push(moved);
    let band = b.object(Object::full_screen("depth layers band", [1.0; 4]));
    let main = b.pass(PassSpec::clear(1.0));
    let layer = b.pass(PassSpec {
        target: Target::DepthSlice { level: 0, layer: 1 },
        ..PassSpec::clear(1.0)
    });
    let post = b.pass(PassSpec {
        target: Target::Post,
        depth: DepthLoad::Load,
        load_color: true,
        ..PassSpec::clear(1.0)
    });
    let flat = b.pipeline(PipelineSpec::standard("flat", main));
    let depth_only = b.pipeline(PipelineSpec {
        program: Program::DepthOnly,
        color_write: false,
        ..PipelineSpec::standard("layer 1, depth only", layer)
    });
    let shade = b.pipeline(PipelineSpec {
        program: Program::DepthLayersPost,
        depth_test: DepthTest::Off,
        depth_write: false,
        ..PipelineSpec::standard("depth layers bands", post)
    });
    if stepwise {
        // Layer 1 first as layer 0 is (the near cube in place), both layers made readable
        // and back: the twin holds both.
        b.step(Step::BeginPass(layer));
        b.step(Step::Bind(depth_only));
        b.draw(&objects);
        b.step(Step::EndPass);
    }
    b.step(Step::BeginPass(main));
    b.step(Step::Bind(flat));
    b.draw(&objects);
    b.step(Step::EndPass);
    if stepwise {
        b.step(Step::MainDepthLayout {
            from: DepthLayout::Attachment,
            to: DepthLayout::Sampled,
        });
        b.step(Step::MainDepthLayout {
            from: DepthLayout::Sampled,
            to: DepthLayout::Attachment,
        });
    }
    b.step(Step::BeginPass(layer));
    b.step(Step::Bind(depth_only));
    b.draw(&second);
    b.step(Step::EndPass);
    b.step(Step::MainDepthLayout {
        from: DepthLayout::Attachment,
        to: DepthLayout::Sampled,
    });
    b.step(Step::BeginPass(post));
    b.step(Step::Bind(shade));
    b.step(Step::Draw(band));
    b.step(Step::EndPass);
    b.step(Step::MainDepthLayout {
        from: DepthLayout::Sampled,
        to: DepthLayout::Attachment,
    });
    b.finish(name, camera, None)
}
