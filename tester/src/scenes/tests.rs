//! The claims the scene builders make about depth values, checked in f64.

use super::passes::{MIDDLE_CUBE_HALF, NEAR_CUBE_HALF};
use super::*;
use crate::scene::View;
use clap::ValueEnum;
use glam::DVec4;

const ASPECT: f64 = 1.0;

fn all() -> Vec<Scene> {
    SceneId::value_variants()
        .iter()
        .map(|id| id.build())
        .collect()
}

fn find(scene: &Scene, name: &str) -> usize {
    scene
        .objects
        .iter()
        .position(|o| o.name == name)
        .unwrap_or_else(|| panic!("{}: no object {name}", scene.name))
}

fn clip(scene: &Scene, view: View, object: usize) -> Vec<DVec4> {
    let o = &scene.objects[object];
    let mvp = scene.mvp_in(view, o, ASPECT);
    scene
        .vertex_positions(o)
        .into_iter()
        .map(|p| mvp * p.extend(1.0))
        .collect()
}

/// (min, max) of the object's NDC depth (its vertices: planar faces reach their extremes
/// there, and depth is monotonic in view distance).
fn depth_range(scene: &Scene, object: usize) -> (f64, f64) {
    clip(scene, View::Camera, object)
        .iter()
        .map(|c| c.z / c.w)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| {
            (lo.min(z), hi.max(z))
        })
}

fn depth_range_of(scene: &Scene, name: &str) -> (f64, f64) {
    depth_range(scene, find(scene, name))
}

/// NDC (x, y) bounding box: (min, max).
fn screen_box(scene: &Scene, name: &str) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for c in clip(scene, View::Camera, find(scene, name)) {
        for (axis, v) in [c.x / c.w, c.y / c.w].into_iter().enumerate() {
            lo[axis] = lo[axis].min(v);
            hi[axis] = hi[axis].max(v);
        }
    }
    (lo, hi)
}

/// Which objects a plan draws in passes of `target`.
fn drawn_in(scene: &Scene, target: Target) -> Vec<usize> {
    let mut current = None;
    let mut drawn = Vec::new();
    for step in scene.plan.all_steps() {
        match step {
            Step::BeginPass(n) => current = Some(scene.plan.passes[*n].target),
            Step::Draw(n) | Step::DrawPushed(n) if current == Some(target) => {
                drawn.push(*n);
            }
            _ => {}
        }
    }
    drawn
}

/// The accuracy scenes (issue #6): many objects, and checked by `crate::accuracy`.
const ACCURACY: [&str; 7] = [
    "sloped-plane",
    "mars-patch",
    "tori",
    "plane-stack",
    "deep-range",
    "decal-bias",
    "far-objects",
];

/// A margin well above the depth resolution of every format (D16: 1.5e-5).
const MARGIN: f64 = 4e-4;

#[test]
fn the_catalog_matches_the_cli() {
    let ids = SceneId::value_variants();
    assert_eq!(CATALOG.len(), ids.len());
    for (entry, id) in CATALOG.iter().zip(ids) {
        assert_eq!(entry.id, *id);
        assert_eq!(id.to_possible_value().unwrap().get_name(), entry.name);
        assert_eq!((entry.build)().name, entry.name);
    }
}

#[test]
fn every_plan_is_valid_and_draws_every_object() {
    for scene in all() {
        scene
            .plan
            .check(scene.objects.len(), scene.light.is_some())
            .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
        let mut drawn: Vec<usize> = drawn_in(&scene, Target::Main);
        let slices = scene
            .plan
            .passes
            .iter()
            .map(|p| p.target)
            .filter(|t| matches!(t, Target::DepthSlice { .. }));
        for target in [Target::Shadow, Target::SoftParticles, Target::Post]
            .into_iter()
            .chain(slices)
        {
            drawn.extend(drawn_in(&scene, target));
        }
        for n in 0..scene.objects.len() {
            assert!(
                drawn.contains(&n),
                "{}: {} is never drawn",
                scene.name,
                scene.objects[n].name
            );
        }
        assert!(
            scene.objects.len() <= 16 || ACCURACY.contains(&scene.name),
            "{}: too many objects",
            scene.name
        );
    }
}

#[test]
fn every_vertex_is_within_the_depth_range_of_its_views() {
    for scene in all() {
        for (target, view) in [(Target::Main, View::Camera), (Target::Shadow, View::Light)] {
            // OpenGL's clip depth runs over [-1, 1]; the others over [0, 1].
            let negative_one_to_one =
                view == View::Camera && scene.camera.projection.negative_one_to_one();
            let lowest = if negative_one_to_one { -1.0 } else { 0.0 };
            let clamped = scene.plan.clamped_objects();
            for n in drawn_in(&scene, target) {
                if clamped.contains(&n) {
                    // Drawn with depth clamping, beyond a plane on purpose.
                    continue;
                }
                for c in clip(&scene, view, n) {
                    let name = scene.objects[n].name;
                    assert!(c.w > 0.0, "{}: {name} behind the eye", scene.name);
                    let z = c.z / c.w;
                    assert!(
                        (lowest..=1.0).contains(&z),
                        "{}: {name} has depth {z} in {view:?}",
                        scene.name
                    );
                }
            }
        }
    }
}

#[test]
fn needs_follow_from_the_plans() {
    let needs = |id: SceneId| id.build().plan.needs();
    assert!(needs(SceneId::Stencil).stencil);
    assert!(needs(SceneId::DepthBounds).depth_bounds);
    assert!(needs(SceneId::DynamicRendering).dynamic_rendering);
    assert!(needs(SceneId::CompareOpsDynamic).dynamic_compare_op);
    assert!(needs(SceneId::DepthBias).depth_bias_clamp);
    assert!(needs(SceneId::DepthBiasDynamic).depth_bias_clamp);
    assert!(needs(SceneId::ClearImage).clear_depth_image);
    assert!(needs(SceneId::PipelineLibrary).graphics_pipeline_library);
    assert!(needs(SceneId::ShadowMap).shadow_map);
    assert_eq!(needs(SceneId::Secondary).secondaries, 2);
    assert_eq!(needs(SceneId::Overlap), crate::plan::Needs::default());
    let unrestricted = needs(SceneId::DepthRangeUnrestricted);
    assert!(unrestricted.depth_range_unrestricted && unrestricted.depth_clamp);
    assert!(!needs(SceneId::ViewportSplit).depth_range_unrestricted);
    for id in [SceneId::MsaaResolve, SceneId::MsaaResolveDynamic] {
        let needs = needs(id);
        assert_eq!(
            needs.multisample,
            Some(Multisample {
                samples: MSAA_SAMPLES,
                depth_resolve: ResolveMode::SampleZero,
                sampled_depth: false,
            })
        );
        assert_eq!(needs.dynamic_rendering, id == SceneId::MsaaResolveDynamic);
    }
    let reads = needs(SceneId::DepthReads);
    assert!(reads.sampled_depth && reads.depth_tiles && reads.dynamic_rendering);
    for id in [SceneId::DepthMips, SceneId::DepthLayers] {
        let needs = needs(id);
        assert!(needs.sampled_depth && !needs.depth_tiles, "{id:?}");
    }
    let stencil_reads = needs(SceneId::StencilReads);
    assert!(stencil_reads.sampled_depth && stencil_reads.stencil && !stencil_reads.depth_tiles);
    for id in [SceneId::DeferredDepth, SceneId::DeferredDepthTested] {
        // An input attachment, nothing sampled, and no feature beyond Vulkan 1.0's.
        assert_eq!(
            needs(id),
            crate::plan::Needs {
                input_depth: true,
                ..crate::plan::Needs::default()
            },
            "{id:?}"
        );
    }
    for scene in all() {
        let needs = scene.plan.needs();
        assert_eq!(
            needs.input_depth,
            scene.name.starts_with("deferred-depth"),
            "{}",
            scene.name
        );
        if !matches!(scene.name, "stencil" | "stencil-reads") {
            assert!(!needs.stencil, "{}", scene.name);
        }
        if !matches!(
            scene.name,
            "depth-reads"
                | "stencil-reads"
                | "depth-mips"
                | "depth-layers"
                | "depth-layers-stepwise"
                | "multiview"
                | "multiview-dynamic"
        ) {
            assert!(!needs.sampled_depth && !needs.depth_tiles, "{}", scene.name);
        }
        // Two views, two layers of both images, the feature: only the multiview scenes.
        let views = if scene.name.starts_with("multiview") {
            2
        } else {
            0
        };
        assert_eq!(needs.views, views, "{}", scene.name);
        // One level and layer but where a scene names more; blits only between levels.
        let subresources = match scene.name {
            "depth-mips" => (DEPTH_MIP_LEVELS, 1),
            "depth-layers" | "depth-layers-stepwise" | "multiview" | "multiview-dynamic" => (1, 2),
            _ => (1, 1),
        };
        let got = needs.depth_subresources;
        assert_eq!((got.levels, got.layers), subresources, "{}", scene.name);
        assert_eq!(
            needs.depth_blits,
            scene.name == "depth-mips",
            "{}",
            scene.name
        );
        if scene.name != "depth-bounds" {
            assert!(!needs.depth_bounds, "{}", scene.name);
        }
        if !scene.name.starts_with("depth-range-unrestricted") {
            assert!(
                !needs.depth_range_unrestricted && !needs.depth_clamp,
                "{}",
                scene.name
            );
        }
        assert_eq!(
            needs.multisample.is_some(),
            scene.name.starts_with("msaa-") || scene.name == "depth-reads-msaa",
            "{}",
            scene.name
        );
    }
}

#[test]
fn overlap_based_scenes_keep_the_overlap_geometry() {
    let overlap = overlap();
    for id in [
        SceneId::Secondary,
        SceneId::Subpasses,
        SceneId::MsaaResolve,
        SceneId::MsaaResolveDynamic,
        SceneId::DeferredDepth,
        SceneId::DeferredDepthTested,
    ] {
        let scene = id.build();
        let mut names: Vec<&str> = scene
            .objects
            .iter()
            .map(|o| o.name)
            .filter(|name| !name.contains("depth input band"))
            .collect();
        let mut expected: Vec<&str> = overlap.objects.iter().map(|o| o.name).collect();
        names.sort_unstable();
        expected.sort_unstable();
        assert_eq!(names, expected, "{}", scene.name);
    }
    assert_eq!(secondary().objects, overlap.objects);
    // The multisampled scenes draw the overlap objects in the overlap order, with its
    // camera: only the sample count and the resolves differ.
    for scene in [msaa_resolve(), msaa_resolve_dynamic()] {
        assert_eq!(scene.objects, overlap.objects, "{}", scene.name);
        assert_eq!(scene.camera, overlap.camera, "{}", scene.name);
        assert_eq!(scene.plan.steps, overlap.plan.steps, "{}", scene.name);
    }
}

/// `depth-reads-msaa`: the overlap objects (each drawn once into the single-sample main
/// images and once at 4x MSAA), a 4x depth kept for shaders (not resolved, so the main depth
/// is not sampled), read by the post pass between barriers into and out of the sampled layout.
#[test]
fn depth_reads_msaa_samples_the_kept_multisampled_depth() {
    let overlap = overlap();
    let scene = depth_reads_msaa();
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name).collect();
    let expected: Vec<&str> = overlap.objects.iter().map(|o| o.name).collect();
    assert_eq!(names[..expected.len()].len(), expected.len());
    for name in &expected {
        assert_eq!(
            names.iter().filter(|n| *n == name).count(),
            1,
            "{name} in {names:?}"
        );
    }
    assert_eq!(scene.objects.len(), expected.len() + 1);
    let needs = scene.plan.needs();
    assert_eq!(
        needs.multisample,
        Some(Multisample {
            samples: MSAA_SAMPLES,
            depth_resolve: ResolveMode::SampleZero,
            sampled_depth: true,
        })
    );
    assert!(!needs.sampled_depth && !needs.depth_tiles && !needs.dynamic_rendering);
    let draws = |pass: usize| {
        let mut current = None;
        scene
            .plan
            .steps
            .iter()
            .filter(|step| {
                if let Step::BeginPass(n) = step {
                    current = Some(*n);
                }
                current == Some(pass) && matches!(step, Step::Draw(_))
            })
            .count()
    };
    assert_eq!(
        (draws(0), draws(1), draws(2)),
        (expected.len(), expected.len(), 1)
    );
    assert!(scene.plan.passes[1]
        .multisample
        .is_some_and(|m| m.sampled_depth));
    assert_eq!(scene.plan.passes[2].target, Target::Post);
    let layouts: Vec<&Step> = scene
        .plan
        .steps
        .iter()
        .filter(|s| matches!(s, Step::MultisampledDepthLayout { .. }))
        .collect();
    assert_eq!(layouts.len(), 2);
    // `--depth-resolve` applies to no pass: the depth is not resolved.
    let mut plan = scene.plan.clone();
    assert!(!plan.set_depth_resolve(ResolveMode::Average));
    // The post pass needs the multisampled depth in the sampled layout.
    let mut broken = scene.plan.clone();
    broken
        .steps
        .retain(|s| !matches!(s, Step::MultisampledDepthLayout { .. }));
    assert!(broken.check(scene.objects.len(), false).is_err());
    // And a multisampled pass that keeps its depth is a render pass.
    let mut broken = scene.plan.clone();
    broken.passes[1].kind = PassKind::DynamicRendering;
    assert!(broken.check(scene.objects.len(), false).is_err());
}

#[test]
fn compare_ops_overlay_tiles_are_ground_tiles() {
    for scene in [compare_ops(), compare_ops_dynamic(), compare_ops_unsorted()] {
        let ground = &scene.objects[find(&scene, "ground")];
        let checker = &scene.objects[find(&scene, "checker overlay")];
        assert_eq!(ground.model, checker.model);
        assert_eq!(
            checker.mesh.positions.len() * 2,
            ground.mesh.positions.len()
        );
        // Every overlay tile is a ground tile: the same 4 vertices, the same triangles.
        for tile in checker.mesh.positions.chunks_exact(4) {
            assert!(
                ground.mesh.positions.chunks_exact(4).any(|t| t == tile),
                "{}: overlay tile {tile:?} is not a ground tile",
                scene.name
            );
        }
        assert_eq!(
            &checker.mesh.indices[..6],
            &ground.mesh.indices[..6],
            "same triangulation"
        );
    }
}

#[test]
fn compare_ops_extras_sit_where_their_op_shows_them() {
    let scene = compare_ops();
    // The ALWAYS cube is behind the middle cube, and inside its screen box.
    let (always, middle) = (
        depth_range_of(&scene, "always cube"),
        depth_range_of(&scene, "middle cube"),
    );
    assert!(always.0 > middle.0);
    let (alo, ahi) = screen_box(&scene, "always cube");
    let (mlo, mhi) = screen_box(&scene, "middle cube");
    assert!(alo[0] > mlo[0] && ahi[0] < mhi[0] && alo[1] > mlo[1] && ahi[1] < mhi[1]);
    // The GREATER cube is behind the near cube and overlaps it on screen.
    assert!(depth_range_of(&scene, "greater cube").0 > depth_range_of(&scene, "near cube").0);
    let (glo, ghi) = screen_box(&scene, "greater cube");
    let (nlo, nhi) = screen_box(&scene, "near cube");
    assert!(glo[0] < nhi[0] && nlo[0] < ghi[0] && glo[1] < nhi[1] && nlo[1] < ghi[1]);
    // The NEVER cube would be in plain view: inside the image, over the ground only.
    let (lo, hi) = screen_box(&scene, "never cube");
    assert!(lo[0] > -1.0 && hi[0] < 1.0 && lo[1] > -1.0 && hi[1] < 1.0);
    for other in ["near cube", "middle cube", "far cube", "slab"] {
        let (olo, ohi) = screen_box(&scene, other);
        assert!(ohi[0] < lo[0] || hi[0] < olo[0] || ohi[1] < lo[1] || hi[1] < olo[1]);
    }
}

#[test]
fn clear_values_never_tie_with_a_surface() {
    let near = ["near floor", "near cube", "near cube 2"];
    let far = ["far floor", "far cube", "far cube 2"];
    for (scene, clear) in [(clear_render_pass(), 0.985), (clear_image(), 0.98)] {
        assert_eq!(scene.plan.main_clear_depth(), clear as f32);
        for name in near {
            assert!(depth_range_of(&scene, name).1 < 0.98 - MARGIN, "{name}");
        }
        for name in far {
            assert!(depth_range_of(&scene, name).0 > 0.985 + MARGIN, "{name}");
        }
        // The middle cube draws with 0.985, not with 0.98.
        let (lo, hi) = depth_range_of(&scene, "middle cube");
        assert!(lo > 0.98 + MARGIN && hi < 0.985 - MARGIN, "{lo} {hi}");
    }
}

/// The deferred-depth scenes: the overlap scene in subpass 0, one band in subpass 1 (over the
/// bottom or the top quarter) drawn with the input-attachment program, whose subpass has a
/// depth attachment only where it tests depth; the tested band lies behind every surface and
/// in front of the cleared background, never within a margin of either.
#[test]
fn deferred_depth_bands_read_the_depth_subpass_0_wrote() {
    for (scene, tested, rows) in [
        (deferred_depth(), false, [0.5, 1.0]),
        (deferred_depth_tested(), true, [-1.0, -0.5]),
    ] {
        let pass = &scene.plan.passes[0];
        assert_eq!(
            pass.kind,
            PassKind::DepthInputSubpasses {
                depth_attached: tested
            },
            "{}",
            scene.name
        );
        assert!(pass.has_depth(0) && pass.has_depth(1) == tested);
        assert!(!pass.reads_depth_input(0) && pass.reads_depth_input(1));
        let band = scene.objects.len() - 1;
        assert_eq!(drawn_in(&scene, Target::Main).last(), Some(&band));
        let shade = &scene.plan.pipelines[1];
        assert_eq!((shade.subpass, shade.program), (1, Program::DepthInput));
        assert!(!shade.depth_write);
        let ([x_lo, y_lo], [x_hi, y_hi]) = screen_box(&scene, scene.objects[band].name);
        assert_eq!([x_lo, x_hi], [-1.0, 1.0], "{}", scene.name);
        assert_eq!([y_lo, y_hi], rows, "{}", scene.name);
        // The census counts the band only where its subpass has the depth attached.
        let census = scene.plan.draw_census();
        assert_eq!(
            census.iter().map(|c| c.3).sum::<usize>(),
            scene.objects.len() - usize::from(!tested),
            "{}",
            scene.name
        );
        if tested {
            assert_eq!(
                shade.depth_test,
                DepthTest::Static(Compare::Greater),
                "{}",
                scene.name
            );
            let depth = DEFERRED_BAND_DEPTH as f32;
            assert_eq!(
                shade.viewport,
                Viewport::Static {
                    min_depth: depth,
                    max_depth: depth,
                }
            );
            assert!(DEFERRED_BAND_DEPTH < f64::from(scene.plan.main_clear_depth()) - MARGIN);
            for n in 0..band {
                let (_, far) = depth_range(&scene, n);
                assert!(
                    far < DEFERRED_BAND_DEPTH - MARGIN,
                    "{}: {} reaches depth {far}",
                    scene.name,
                    scene.objects[n].name
                );
            }
        } else {
            assert_eq!(shade.depth_test, DepthTest::Off);
        }
    }
}

/// The local-read scenes are their render pass twins in one dynamic rendering: the same
/// objects, pipelines (but for the band's program: the one the rendering maps the depth to)
/// and steps, the pass a [`PassKind::DynamicRenderingLocalRead`] whose "subpass 1" (after the
/// by-region barrier) reads the depth it keeps attached; they need the local-read feature
/// (with dynamic rendering) and an input attachment, nothing else.
#[test]
fn local_read_scenes_are_their_render_pass_twins_in_one_rendering() {
    for (scene, twin, indexed) in [
        (deferred_depth_local_read(), deferred_depth(), false),
        (deferred_depth_local_read_indexed(), deferred_depth(), true),
        (
            deferred_depth_local_read_tested(),
            deferred_depth_tested(),
            false,
        ),
    ] {
        let name = scene.name;
        assert_eq!(scene.objects, twin.objects, "{name}");
        assert_eq!(scene.camera, twin.camera, "{name}");
        assert_eq!(scene.plan.steps, twin.plan.steps, "{name}");
        let kind = PassKind::DynamicRenderingLocalRead { indexed };
        assert_eq!(scene.plan.passes.len(), 1, "{name}");
        let pass = &scene.plan.passes[0];
        assert_eq!(
            *pass,
            PassSpec {
                kind,
                ..twin.plan.passes[0].clone()
            },
            "{name}"
        );
        assert!(kind.is_dynamic_rendering() && kind.reads_locally());
        // The depth stays attached in both phases; subpass 1 reads it.
        assert!(pass.has_depth(0) && pass.has_depth(1), "{name}");
        assert!(!pass.reads_depth_input(0) && pass.reads_depth_input(1));
        let program = if indexed {
            Program::DepthInput
        } else {
            Program::DepthInputUndecorated
        };
        assert_eq!(kind.depth_input_program(), Some(program));
        for (pipeline, theirs) in scene.plan.pipelines.iter().zip(&twin.plan.pipelines) {
            let expected = if theirs.program == Program::DepthInput {
                program
            } else {
                theirs.program
            };
            assert_eq!(
                *pipeline,
                PipelineSpec {
                    program: expected,
                    ..theirs.clone()
                },
                "{name}"
            );
        }
        // Every draw is counted: the depth is attached throughout.
        let census = scene.plan.draw_census();
        assert_eq!(
            census.iter().map(|c| c.3).sum::<usize>(),
            scene.objects.len(),
            "{name}"
        );
        assert_eq!(
            scene.plan.needs(),
            crate::plan::Needs {
                input_depth: true,
                dynamic_rendering: true,
                dynamic_rendering_local_read: true,
                ..crate::plan::Needs::default()
            },
            "{name}"
        );
        // The other mapping's program in the band is malformed: its variable is not the one
        // the rendering maps the depth to.
        let mut broken = scene.plan.clone();
        broken.pipelines[1].program = if indexed {
            Program::DepthInputUndecorated
        } else {
            Program::DepthInput
        };
        assert!(broken.check(scene.objects.len(), false).is_err(), "{name}");
        // A band that writes the depth it reads is malformed.
        let mut broken = scene.plan.clone();
        broken.pipelines[1].depth_write = true;
        assert!(broken.check(scene.objects.len(), false).is_err(), "{name}");
        // Libraries are for render passes; a local read is not multisampled.
        let mut broken = scene.plan.clone();
        broken.pipelines[0].libraries = true;
        assert!(broken.check(scene.objects.len(), false).is_err(), "{name}");
        let mut broken = scene.plan.clone();
        broken.passes[0].multisample = Some(Multisample {
            samples: MSAA_SAMPLES,
            depth_resolve: ResolveMode::SampleZero,
            sampled_depth: false,
        });
        assert!(broken.check(scene.objects.len(), false).is_err(), "{name}");
        // One input descriptor, one layout: a local read beside a render pass reading the
        // depth as an input attachment is refused.
        let mut mixed = scene.plan.clone();
        mixed.passes.push(twin.plan.passes[0].clone());
        let offset = mixed.pipelines.len();
        mixed
            .pipelines
            .extend(twin.plan.pipelines.iter().map(|p| PipelineSpec {
                pass: 1,
                ..p.clone()
            }));
        mixed
            .steps
            .extend(twin.plan.steps.iter().map(|step| match step {
                Step::BeginPass(_) => Step::BeginPass(1),
                Step::Bind(n) => Step::Bind(n + offset),
                other => other.clone(),
            }));
        let error = mixed.check(scene.objects.len(), false).unwrap_err();
        assert!(error.0.contains("one descriptor"), "{name}: {error}");
    }
}

#[test]
fn clear_attachments_geometry_straddles_the_cleared_depth() {
    let scene = clear_attachments();
    let rect_ndc = CLEAR_RECT.map(|f| f64::from(f) * 2.0 - 1.0);
    let wall = depth_range_of(&scene, "wall");
    let bar = depth_range_of(&scene, "bar behind the wall");
    let block = depth_range_of(&scene, "far block");
    assert!(wall.1 < bar.0, "the bar is behind the wall");
    assert!(
        bar.1 < 0.98 - MARGIN,
        "the bar is nearer than the cleared depth"
    );
    assert!(block.0 > 0.98 + MARGIN, "the far block is beyond it");
    // The wall hides the bar on screen, the bar crosses the rectangle's sides, the block
    // overlaps the rectangle's top and sticks out of it.
    let (wlo, whi) = screen_box(&scene, "wall");
    let (blo, bhi) = screen_box(&scene, "bar behind the wall");
    assert!(wlo[0] < blo[0] && bhi[0] < whi[0] && wlo[1] < blo[1] && bhi[1] < whi[1]);
    assert!(blo[0] < rect_ndc[0] && bhi[0] > rect_ndc[2]);
    assert!(blo[1] > rect_ndc[1] && bhi[1] < rect_ndc[3]);
    let (klo, khi) = screen_box(&scene, "far block");
    assert!(klo[0] < rect_ndc[0] && khi[0] > rect_ndc[2]);
    assert!(klo[1] < rect_ndc[1] && khi[1] > rect_ndc[1]);
}

#[test]
fn decals_are_coplanar_with_their_walls() {
    let scene = depth_bias();
    for (decal, wall) in [
        ("facing decal 1", "facing wall"),
        ("facing decal 2", "facing wall"),
        ("slanted decal 1", "slanted wall"),
        ("slanted decal under the rod", "slanted wall"),
    ] {
        let (d, w) = (
            &scene.objects[find(&scene, decal)],
            &scene.objects[find(&scene, wall)],
        );
        assert_eq!(d.model, w.model);
        assert!(d.mesh.positions.iter().all(|p| p[2] == 0.0));
        assert!(w.mesh.positions.iter().all(|p| p[2] == 0.0));
    }
    // The facing wall's depth is constant (its slope is zero): only the constant factor
    // separates its decals.
    let (lo, hi) = depth_range_of(&scene, "facing wall");
    assert!(hi - lo < 1e-6, "{lo} {hi}");
    // The rod is in front of the slanted wall by far more than the clamp.
    let rod = depth_range_of(&scene, "rod");
    let wall = depth_range_of(&scene, "slanted wall");
    assert!(rod.0 > wall.0 && rod.1 < wall.1);
}

/// Where the ray `origin + t * dir` (t > 0) meets the triangle, as t (Möller-Trumbore).
fn ray_hits(origin: DVec3, dir: DVec3, [a, b, c]: [DVec3; 3]) -> Option<f64> {
    let (e1, e2) = (b - a, c - a);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-15 {
        return None;
    }
    let s = origin - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = dir.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
}

/// The nearest world-space object of `scene` (but those in `skip`) that the ray
/// `origin + t * dir` meets, with its t.
fn nearest_hit(scene: &Scene, origin: DVec3, dir: DVec3, skip: &[usize]) -> Option<(usize, f64)> {
    let mut nearest: Option<(usize, f64)> = None;
    for (n, object) in scene.objects.iter().enumerate() {
        if object.space != Space::World || skip.contains(&n) {
            continue;
        }
        for triangle in object.mesh.triangles() {
            let world = triangle.map(|p| object.model.transform_point3(p));
            if let Some(t) = ray_hits(origin, dir, world) {
                if nearest.is_none_or(|(_, best)| t < best) {
                    nearest = Some((n, t));
                }
            }
        }
    }
    nearest
}

#[test]
fn pipeline_library_builds_every_pipeline_from_static_libraries() {
    let scene = pipeline_library();
    let plan = &scene.plan;
    assert!(plan.needs().graphics_pipeline_library);
    // A render pass: every library is given it and its subpass.
    assert!(plan.passes.iter().all(|p| p.kind == PassKind::RenderPass));
    for pipeline in &plan.pipelines {
        assert!(pipeline.libraries, "{}", pipeline.name);
        // All depth state static: in the libraries' create infos, nowhere else.
        assert!(matches!(pipeline.depth_test, DepthTest::Static(_)));
        assert!(matches!(pipeline.bias, Bias::Off | Bias::Static(_)));
        assert!(matches!(pipeline.viewport, Viewport::Static { .. }));
        assert_eq!(pipeline.bounds, Bounds::Off);
    }
    let spec = |name: &str| {
        plan.pipelines
            .iter()
            .find(|p| p.name == name)
            .unwrap_or_else(|| panic!("no pipeline {name}"))
    };
    assert_eq!(
        spec("standard").depth_test,
        DepthTest::Static(Compare::Less)
    );
    assert_eq!(spec("decal").bias, Bias::Static(DECAL_BIAS));
    assert!(!spec("decal").depth_write);
    assert_eq!(
        spec("sky").viewport,
        Viewport::Static {
            min_depth: 1.0,
            max_depth: 1.0
        }
    );
    assert_eq!(
        spec("sky").depth_test,
        DepthTest::Static(Compare::LessOrEqual)
    );
    // The overlap objects, unchanged.
    for object in overlap().objects {
        assert!(scene.objects.contains(&object), "{}", object.name);
    }
    // No other scene needs the extension.
    for other in all() {
        assert_eq!(
            other.plan.needs().graphics_pipeline_library,
            [
                "pipeline-library",
                "frag-depth-library",
                "pipeline-library-dynamic",
                "frag-depth-library-dynamic",
                "deferred-depth-library",
                "deferred-depth-tested-library"
            ]
            .contains(&other.name),
            "{}",
            other.name
        );
    }
}

#[test]
fn pipeline_library_decals_lie_on_visible_faces_and_the_sky_behind_everything() {
    let scene = pipeline_library();
    let eye = scene.camera.eye;
    let decals = ["near cube decal", "middle cube decal"].map(|name| find(&scene, name));
    for (decal, cube, half) in [
        (decals[0], "near cube", NEAR_CUBE_HALF),
        (decals[1], "middle cube", MIDDLE_CUBE_HALF),
    ] {
        let cube = find(&scene, cube);
        let (d, c) = (&scene.objects[decal], &scene.objects[cube]);
        let name = d.name;
        // Exactly coplanar with the cube's +z face (the same model matrix, the face's own
        // f32 z), and inside its edges.
        assert_eq!(d.model, c.model, "{name}");
        let face_z = half as f32;
        assert!(
            c.mesh
                .positions
                .chunks_exact(4)
                .any(|face| face.iter().all(|p| p[2] == face_z)),
            "{name}: the cube has no face at z = {face_z}"
        );
        for p in &d.mesh.positions {
            assert!(
                p[2] == face_z && p[0].abs() < face_z && p[1].abs() < face_z,
                "{name}"
            );
        }
        // The face turns toward the eye.
        let normal = d.model.transform_vector3(DVec3::Z);
        assert!(normal.dot(eye - d.world_center()) > 0.0, "{name}");
        // Over the whole decal (a 10 x 10 grid of points), the nearest surface the eye sees
        // is the decal's own face, at the decal: nothing else is in front of it, so the
        // bias alone decides whether it shows. And it is inside the image.
        let corners: Vec<DVec3> = d.mesh.positions_f64().collect();
        let view_projection = scene.view_projection(ASPECT);
        for i in 0..10 {
            for j in 0..10 {
                let (u, v) = ((f64::from(i) + 0.5) / 10.0, (f64::from(j) + 0.5) / 10.0);
                let local =
                    corners[0] + u * (corners[1] - corners[0]) + v * (corners[3] - corners[0]);
                let point = d.model.transform_point3(local);
                let (hit, t) = nearest_hit(&scene, eye, point - eye, &decals)
                    .unwrap_or_else(|| panic!("{name}: the eye sees nothing at {point}"));
                assert_eq!(
                    hit, cube,
                    "{name}: {} in front at {point}",
                    scene.objects[hit].name
                );
                assert!((t - 1.0).abs() < 1e-9, "{name}: t = {t}");
                let ndc = view_projection.project_point3(point);
                assert!(ndc.x.abs() < 1.0 && ndc.y.abs() < 1.0, "{name} at {ndc}");
            }
        }
    }
    // The sky (viewport [1, 1], LESS_OR_EQUAL) passes only on the clear value: every
    // surface is nearer than 1 by far more than any format's resolution...
    let sky = find(&scene, "sky");
    for n in (0..scene.objects.len()).filter(|&n| n != sky) {
        let (_, far) = depth_range(&scene, n);
        assert!(far < 1.0 - MARGIN, "{}: {far}", scene.objects[n].name);
    }
    // ...and the top corners of the image see no surface (the sky shows there), the
    // bottom ones the ground.
    let inverse = scene.view_projection(ASPECT).inverse();
    let ground = find(&scene, "ground");
    for (x, y, sees) in [
        (-0.95, -0.95, None),
        (0.95, -0.95, None),
        (-0.95, 0.95, Some(ground)),
        (0.95, 0.95, Some(ground)),
    ] {
        let through = inverse.project_point3(DVec3::new(x, y, 0.5));
        let hit = nearest_hit(&scene, eye, through - eye, &[]).map(|(n, _)| n);
        assert_eq!(hit, sees, "at ({x}, {y})");
    }
}

#[test]
fn viewport_split_ranges_separate_the_weapon_from_the_world() {
    let scene = viewport_split();
    let map = |[a, b]: [f32; 2], d: f64| f64::from(a) + (f64::from(b) - f64::from(a)) * d;
    let weapon = depth_range_of(&scene, "weapon");
    let post = depth_range_of(&scene, "lamp post");
    assert!(map(SPLIT_RANGES[0], weapon.1) + MARGIN < map(SPLIT_RANGES[1], 0.0));
    // The post is physically in front of the weapon's far end.
    assert!(post.0 < weapon.1);
    // The squeezed cube is physically in front of the far cube but lands behind it.
    let cube = depth_range_of(&scene, "squeezed cube");
    let far = depth_range_of(&scene, "far cube");
    assert!(cube.1 < far.1);
    assert!(map(SPLIT_RANGES[2], cube.0) > map(SPLIT_RANGES[1], far.1) + MARGIN);
    let (clo, chi) = screen_box(&scene, "squeezed cube");
    let (flo, fhi) = screen_box(&scene, "far cube");
    assert!(
        clo[0] < flo[0] && flo[0] < chi[0],
        "the cube crosses the far cube's edge"
    );
    assert!(clo[1] > -1.0 && chi[1] < flo[1] + 0.5 * (fhi[1] - flo[1]));
}

/// How one depth convention stores depth: the clear value, whether LESS is swapped for
/// GREATER, the depth rasterized for a surface at standard depth D (what flat programs
/// store and `gl_FragCoord.z` holds), and the maps applied to `gl_FragCoord.z` loads and
/// `FragDepth` stores of [`Program::FragDepth`] (a layer's rewrite; identity natively).
struct Convention {
    name: &'static str,
    clear: f64,
    greater: bool,
    rasterized: &'static dyn Fn(f64) -> f64,
    load: &'static dyn Fn(f64) -> f64,
    store: &'static dyn Fn(f64) -> f64,
}

/// The stored depth of `frag-depth`'s object `n` (its cards have one depth each) under
/// `convention`, drawn with `program`.
fn card_depth(scene: &Scene, n: usize, program: Program, convention: &Convention) -> f64 {
    let (lo, hi) = depth_range(scene, n);
    assert!(
        hi - lo < 1e-9,
        "{}: not facing the eye",
        scene.objects[n].name
    );
    let rasterized = (convention.rasterized)(lo);
    match program {
        Program::FragDepth => (convention.store)(program.frag_depth((convention.load)(rasterized))),
        _ => rasterized,
    }
}

/// Replays `frag-depth`'s draws at the NDC point `at` (the cards are rectangles facing the
/// eye: their screen boxes are what they cover) with `convention`: the object that shows
/// there, if any. Every depth test is asserted to be decided by more than [`MARGIN`].
fn frag_depth_winner(scene: &Scene, at: [f64; 2], convention: &Convention) -> Option<usize> {
    let mut stored = convention.clear;
    let mut shows = None;
    let mut program = Program::Flat;
    for step in &scene.plan.steps {
        match step {
            Step::Bind(p) => {
                let pipeline = &scene.plan.pipelines[*p];
                assert_eq!(pipeline.depth_test, DepthTest::Static(Compare::Less));
                assert!(pipeline.depth_write);
                program = pipeline.program;
            }
            Step::Draw(n) => {
                let (lo, hi) = screen_box(scene, scene.objects[*n].name);
                if !(lo[0] < at[0] && at[0] < hi[0] && lo[1] < at[1] && at[1] < hi[1]) {
                    continue;
                }
                let depth = card_depth(scene, *n, program, convention);
                assert!(
                    (depth - stored).abs() > MARGIN,
                    "{}: {} ties at {at:?}: {depth} against {stored}",
                    convention.name,
                    scene.objects[*n].name
                );
                let op = if convention.greater {
                    Compare::Greater
                } else {
                    Compare::Less
                };
                if op.passes(depth, stored) {
                    stored = depth;
                    shows = Some(*n);
                }
            }
            _ => {}
        }
    }
    shows
}

#[test]
fn frag_depth_library_is_frag_depth_built_from_libraries() {
    let (plain, library) = (frag_depth(), frag_depth_library());
    assert!(library.plan.needs().graphics_pipeline_library);
    assert_eq!(library.objects, plain.objects);
    assert_eq!(library.plan.steps, plain.plan.steps);
    assert_eq!(library.plan.passes, plain.plan.passes);
    assert!(library
        .plan
        .passes
        .iter()
        .all(|p| p.kind == PassKind::RenderPass));
    for (with, without) in library.plan.pipelines.iter().zip(&plain.plan.pipelines) {
        assert!(with.libraries, "{}", with.name);
        assert_eq!(
            &PipelineSpec {
                libraries: false,
                ..with.clone()
            },
            without
        );
    }
}

#[test]
fn frag_depth_pushes_the_near_card_between_the_others() {
    let scene = frag_depth();
    let [wall, pushed, middle] =
        ["far wall", "pushed card", "middle card"].map(|name| find(&scene, name));
    assert_eq!(scene.plan.main_clear_depth(), 1.0);
    // Standard depths: the pushed card is geometrically the nearest...
    let depth = |n| depth_range(&scene, n).0;
    assert!(depth(pushed) + MARGIN < depth(middle) && depth(middle) + MARGIN < depth(wall));
    // ...and its FragDepth puts it between the middle card and the wall.
    let pushed_back = Program::FragDepth.frag_depth(depth(pushed));
    assert_eq!(pushed_back, 0.5 + 0.5 * depth(pushed));
    assert!(depth(middle) + MARGIN < pushed_back && pushed_back + MARGIN < depth(wall));
    assert!(
        pushed_back < 1.0 - MARGIN,
        "in front of the clear with margin"
    );

    // Which object shows where: (point in NDC, natively, under a layer that forgets to map
    // FragDepth stores or gl_FragCoord.z loads). Only the overlap of the pushed and the
    // middle card changes.
    let regions = [
        ([0.0, -0.4], Some(pushed), Some(pushed)), // the pushed card alone (upper band)
        ([0.0, 0.05], Some(pushed), Some(pushed)), // the pushed card alone (between)
        ([-0.3, 0.05], Some(pushed), Some(pushed)), // the pushed card over the wall
        ([0.3, 0.05], Some(middle), Some(pushed)), // the middle card over the pushed card
        ([-0.6, 0.5], Some(wall), Some(wall)),
        ([0.6, 0.5], Some(middle), Some(middle)),
        ([0.0, 0.5], None, None),
        ([-0.9, -0.9], None, None),
    ];
    let flip = &|d: f64| 1.0 - d;
    let same = &|d: f64| d;
    // Infinite reversed-Z stores n/w = 1 - (1 - n/f) D; a rewrite baking the complementary
    // map is off by up to n/f = 1e-3 (the scenes' margins must absorb it).
    assert_eq!((scene.camera.near, scene.camera.far), (0.1, 100.0));
    let infinite = &|d: f64| 1.0 - (1.0 - 0.1 / 100.0) * d;
    let native = Convention {
        name: "native",
        clear: 1.0,
        greater: false,
        rasterized: same,
        load: same,
        store: same,
    };
    let reversed = |name, rasterized, load, store| Convention {
        name,
        clear: 0.0,
        greater: true,
        rasterized,
        load,
        store,
    };
    let right = [
        reversed("reversed", flip, flip, flip),
        reversed("infinite", infinite, flip, flip),
    ];
    let wrong = [
        reversed("stores unflipped", flip, flip, same),
        reversed("loads unflipped", flip, same, flip),
        reversed("shader untouched", flip, same, same),
        reversed("infinite, stores unflipped", infinite, flip, same),
        reversed("infinite, loads unflipped", infinite, same, flip),
    ];
    for (at, expected, when_wrong) in regions {
        assert_eq!(
            frag_depth_winner(&scene, at, &native),
            expected,
            "native at {at:?}"
        );
        for convention in &right {
            assert_eq!(
                frag_depth_winner(&scene, at, convention),
                expected,
                "{} at {at:?}",
                convention.name
            );
        }
        for convention in &wrong {
            assert_eq!(
                frag_depth_winner(&scene, at, convention),
                when_wrong,
                "{} at {at:?}",
                convention.name
            );
        }
    }

    // The cards overlap as the regions say, and stay inside the image.
    for name in ["far wall", "pushed card", "middle card"] {
        let (lo, hi) = screen_box(&scene, name);
        assert!(
            lo[0] > -1.0 && lo[1] > -1.0 && hi[0] < 1.0 && hi[1] < 1.0,
            "{name}"
        );
    }
    // No ground truth: the nearest surface does not win.
    let refused = crate::ground_truth::applies(&scene).unwrap_err();
    assert!(refused.contains("FragDepth"), "{refused}");
}

/// The scenes with a ground truth: exactly those where the nearest surface decides.
#[test]
fn ground_truth_applies_where_the_nearest_surface_wins() {
    let with: Vec<&str> = all()
        .iter()
        .filter(|s| crate::ground_truth::applies(s).is_ok())
        .map(|s| s.name)
        .collect();
    assert_eq!(
        with,
        [
            "overlap",
            "secondary",
            "dynamic-rendering",
            // One rendering, recorded as two instances.
            "dynamic-rendering-suspended",
            "dynamic-rendering-suspended-across",
            "dynamic-rendering-secondaries",
            "shadow-map",
            "shadow-map-secondaries",
            "shadow-map-raw",
            "shadow-map-x8-d24",
            "shadow-map-perspective",
            "shadow-map-perspective-secondaries",
            // Its later passes write no depth.
            "depth-reads",
            // Their later passes and blits write other levels and layers than the one read
            // back.
            "depth-mips",
            "depth-layers",
            "depth-layers-stepwise",
            // Layer 0 is view 0 (the camera); the post pass writes no depth.
            "multiview",
            "multiview-dynamic",
            "projection-only",
            "view-projection",
            "model-view-projection-pair",
            "row-major",
            "opengl-depth",
            "already-reversed",
            "push-partial",
            "threads",
            "lit-mvp",
            "sloped-plane",
            "mars-patch",
            "tori",
            "plane-stack",
            "deep-range",
            "far-objects",
        ]
    );
    for scene in all() {
        let Ok(drawn) = crate::ground_truth::applies(&scene) else {
            continue;
        };
        let (truth, report) = crate::ground_truth::compute(&scene, 96, 64).unwrap();
        assert_eq!(drawn.len(), report.objects.len());
        assert!(
            truth.interior > 96 * 64 / 2 || ACCURACY.contains(&scene.name),
            "{}: {} interior pixels",
            scene.name,
            truth.interior
        );
        // Every object drawn shows somewhere, except what the scene hides on purpose.
        for object in &report.objects {
            let shows = truth.ids.contains(&object.id);
            assert!(
                shows || scene.name == "shadow-map" || scene.name == "plane-stack",
                "{}: {}",
                scene.name,
                object.name
            );
        }
    }
}

/// View 1 of the multiview scenes, whose layer the tester reads back with its own ground
/// truth: seen from the second eye, whose P * V is the views' buffer's second matrix (what
/// the vertex stage applies to that layer, and what its ground truth reports as pushed); it
/// sees every object, elsewhere than view 0 does, with as many interior pixels as the other
/// scenes' truths. View 0 is the scene itself.
#[test]
fn the_second_view_is_seen_from_the_second_eye() {
    let aspect = 96.0 / 64.0;
    for scene in [multiview(), multiview_dynamic()] {
        assert_eq!(scene.seen_from(0).camera, scene.camera);
        let seen = scene.seen_from(1);
        let second = seen.view_projection(aspect).as_mat4().to_cols_array();
        let block: Vec<u8> = second.iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(scene.views_block(aspect)[64..], block[..], "{}", scene.name);
        let (first, _) = crate::ground_truth::compute(&scene, 96, 64).unwrap();
        let (truth, report) = crate::ground_truth::compute(&seen, 96, 64).unwrap();
        assert_ne!(truth.ids, first.ids, "{}", scene.name);
        assert!(truth.interior > 96 * 64 / 2, "{}", scene.name);
        for object in &report.objects {
            assert!(truth.ids.contains(&object.id), "{}", object.name);
            assert_eq!(object.pushed_projection, second, "{}", object.name);
        }
    }
}

/// Replays a plan's push constants byte by byte (per command buffer, as Vulkan keeps them):
/// at every draw without a push, the bytes there are exactly the drawn object's own.
#[test]
fn partial_pushes_leave_every_object_its_own_constants() {
    let mut replayed = 0;
    for scene in all() {
        let aspect = 1.5;
        let lists: Vec<Vec<&Step>> = {
            let mut lists = vec![Vec::new()];
            for step in &scene.plan.steps {
                match step {
                    Step::ExecuteSecondaries(inner, _) => {
                        lists.extend(inner.iter().map(|l| l.iter().collect()));
                    }
                    other => lists[0].push(other),
                }
            }
            lists
        };
        for list in lists {
            let mut bytes = [0u8; 128];
            let mut program = Program::Flat;
            for step in list {
                match step {
                    Step::Bind(n) => program = scene.plan.pipelines[*n].program,
                    Step::Draw(n) => {
                        let own = scene.push_constants(program, &scene.objects[*n], aspect);
                        bytes[..own.len()].copy_from_slice(&own);
                    }
                    Step::Push {
                        object,
                        offset,
                        size,
                    } => {
                        let own = scene.push_constants(program, &scene.objects[*object], aspect);
                        let range = *offset as usize..(offset + size) as usize;
                        bytes[range.clone()].copy_from_slice(&own[range]);
                    }
                    Step::DrawPushed(n) => {
                        let own = scene.push_constants(program, &scene.objects[*n], aspect);
                        assert_eq!(
                            &bytes[..own.len()],
                            &own[..],
                            "{}: {} is drawn with someone else's constants",
                            scene.name,
                            scene.objects[*n].name
                        );
                        replayed += 1;
                    }
                    _ => {}
                }
            }
        }
    }
    assert_eq!(
        replayed, 4,
        "push-partial has four draws without a full push"
    );
}

#[test]
fn push_partial_updates_the_ranges_it_claims() {
    let scene = push_partial();
    let pushes: Vec<(&str, u32, u32)> = scene
        .plan
        .steps
        .iter()
        .filter_map(|step| match step {
            Step::Push {
                object,
                offset,
                size,
            } => Some((scene.objects[*object].name, *offset, *size)),
            _ => None,
        })
        .collect();
    assert_eq!(
        pushes,
        [
            ("lid", 64, 16),
            ("moved cube", 48, 16),
            ("green cube", 0, 32),
            ("green cube", 32, 48),
            ("pillar", 0, 48),
            ("pillar", 64, 16),
        ]
    );
    // What the partial pushes skip really is shared: the lid's matrix is the red cube's,
    // the moved cube differs from the lid only in the translation column (and keeps its
    // color), the pillar from the green cube only in the first three columns and color.
    let bytes = |name| scene.push_constants(Program::Flat, &scene.objects[find(&scene, name)], 1.0);
    let (red, lid, moved) = (bytes("red cube"), bytes("lid"), bytes("moved cube"));
    assert_eq!(red[..64], lid[..64]);
    assert_ne!(red[64..], lid[64..]);
    assert_eq!(lid[..48], moved[..48]);
    assert_eq!(lid[64..], moved[64..]);
    assert_ne!(lid[48..64], moved[48..64]);
    let (green, pillar) = (bytes("green cube"), bytes("pillar"));
    assert_eq!(green[48..64], pillar[48..64]);
    assert_ne!(green[..48], pillar[..48]);
    assert_ne!(green[64..], pillar[64..]);
}

#[test]
fn programs_lay_out_the_same_transform_their_own_way() {
    let scene = model_view_projection_pair();
    let object = &scene.objects[find(&scene, "middle cube")];
    let mvp = scene.mvp(object, ASPECT);
    let floats = |bytes: Vec<u8>| -> Vec<f32> {
        bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    };
    // Row-major: the transpose of the column-major bytes, then the color.
    let columns = floats(scene.push_constants(Program::Flat, object, ASPECT));
    for program in [Program::RowMajor, Program::RowVector] {
        let rows = floats(scene.push_constants(program, object, ASPECT));
        for r in 0..4 {
            for c in 0..4 {
                assert_eq!(rows[r * 4 + c], columns[c * 4 + r]);
            }
        }
        assert_eq!(rows[16..], columns[16..]);
    }
    // The pair: M at 0, P * V at 64, no color; P * V is what a layer sees as projection,
    // and the two stages compose to the MVP.
    let pair = floats(scene.push_constants(Program::MvpPair, object, ASPECT));
    assert_eq!(pair.len(), 32);
    assert_eq!(pair[..16], object.model.as_mat4().to_cols_array());
    let view_projection = scene.view_projection(ASPECT).as_mat4().to_cols_array();
    assert_eq!(pair[16..], view_projection);
    assert_eq!(
        scene.pushed_projection(Program::MvpPair, object, ASPECT),
        view_projection
    );
    let stages = scene.matrix_stages(Program::MvpPair, View::Camera, object, ASPECT);
    assert!((stages[0] * stages[1]).abs_diff_eq(mvp, 1e-12));
}

#[test]
fn baked_vertices_land_where_the_world_path_puts_them() {
    for scene in [projection_only(), view_projection()] {
        let space = scene.objects[0].space;
        assert!(matches!(space, Space::ViewBaked | Space::WorldBaked));
        let pushed = scene.mvp_in(View::Camera, &scene.objects[0], ASPECT);
        let expected = match space {
            Space::ViewBaked => scene.camera.projection(ASPECT),
            _ => scene.view_projection(ASPECT),
        };
        assert_eq!(pushed, expected, "{}", scene.name);
        for object in &scene.objects {
            let world = Object {
                space: Space::World,
                ..object.clone()
            };
            let by_world = scene.mvp_in(View::Camera, &world, ASPECT);
            let by_bake = scene.mvp_in(View::Camera, object, ASPECT);
            for (p, q) in object
                .mesh
                .positions_f64()
                .zip(scene.vertex_positions(object))
            {
                let (a, b) = (by_world * p.extend(1.0), by_bake * q.extend(1.0));
                // The bake rounds once to f32: relative 1e-7 of the coordinates.
                assert!((a - b).abs().max_element() < 1e-6 * a.abs().max_element());
            }
        }
    }
}

#[test]
fn view_projection_reaches_far_inside_its_planes() {
    let scene = view_projection();
    let camera = &scene.camera;
    let farthest = (0..scene.objects.len())
        .flat_map(|n| clip(&scene, View::Camera, n))
        .map(|c| c.w)
        .fold(0.0, f64::max);
    assert!(farthest > 800.0 && farthest < camera.far, "{farthest}");
}

#[test]
fn threads_record_every_object_once_each_list_binding_its_own_state() {
    let scene = threads();
    let [Step::BeginPass(0), Step::ExecuteSecondaries(lists, Recording::ThreadPerSecondary), Step::EndPass] =
        &scene.plan.steps[..]
    else {
        panic!("{:?}", scene.plan.steps);
    };
    assert_eq!(lists.len(), THREADS);
    let mut drawn = Vec::new();
    for list in lists {
        assert!(matches!(list[0], Step::Bind(_)));
        assert!(matches!(list[1], Step::SetViewport { .. }));
        drawn.extend(list.iter().filter_map(|s| match s {
            Step::Draw(n) => Some(*n),
            _ => None,
        }));
    }
    drawn.sort_unstable();
    assert_eq!(drawn, (0..scene.objects.len()).collect::<Vec<_>>());
    assert_eq!(
        scene.plan.needs().secondaries,
        0,
        "no secondary from the main pool"
    );
    let mut names: Vec<&str> = scene.objects.iter().map(|o| o.name).collect();
    let mut expected: Vec<&str> = overlap().objects.iter().map(|o| o.name).collect();
    names.sort_unstable();
    expected.sort_unstable();
    assert_eq!(names, expected);
}

#[test]
fn the_depth_conventions_follow_the_cameras() {
    let gl = opengl_depth();
    assert!(gl.plan.pipelines.iter().all(|p| p.negative_one_to_one));
    assert!(gl.plan.needs().depth_clip_control);
    let reversed = already_reversed();
    assert_eq!(reversed.plan.main_clear_depth(), 0.0);
    assert_eq!(
        reversed.plan.pipelines[0].depth_test,
        DepthTest::Static(Compare::Greater)
    );
    // Depth decreases with distance: the near cube's nearest vertex is above the far
    // cube's farthest.
    let near = depth_range_of(&reversed, "near cube");
    let far = depth_range_of(&reversed, "far cube");
    assert!(near.0 > far.1);
    for scene in all() {
        if scene.name != "opengl-depth" {
            assert!(!scene.plan.needs().depth_clip_control, "{}", scene.name);
        }
    }
}

#[test]
fn shadow_casters_fit_in_the_light_box() {
    let scene = shadow_map();
    for (n, object) in scene.objects.iter().enumerate() {
        if object.name == "ground" {
            continue;
        }
        for c in clip(&scene, View::Light, n) {
            assert!(c.x.abs() < 1.0 && c.y.abs() < 1.0, "{} at {c}", object.name);
        }
    }
    assert_eq!(scene.light_mvps().len(), scene.objects.len());
}

/// The f64 model of `lit_mvp.frag` for the clip transform `mvp` at the model-space point
/// `p` of a flat face spanned by the model-space tangents `tangents`, with base color
/// `color`: linear RGB before the UNORM store. The shader's normal is
/// `cross(dFdx(v), dFdy(v))` of the view vector `v = -(mvp * p).xyz`: the screen
/// derivatives of `v` along a face are the rows 0..2 of `mvp` applied to tangents of the
/// face, so its direction is that of `cross(A t1, A t2)` (A: the linear part of those
/// rows), turned toward `v` as the shader turns it.
fn lit_shade(mvp: &DMat4, p: DVec3, tangents: [DVec3; 2], color: [f32; 4]) -> DVec3 {
    let linear = |t: DVec3| (*mvp * t.extend(0.0)).truncate();
    let v = (-(*mvp * p.extend(1.0)).truncate()).normalize();
    let mut n = linear(tangents[0]).cross(linear(tangents[1])).normalize();
    if n.dot(v) < 0.0 {
        n = -n;
    }
    let l = DVec3::new(-0.35, -0.55, -0.75).normalize();
    let diffuse = n.dot(l).max(0.0);
    // reflect(-l, n) = -l - 2 dot(n, -l) n.
    let reflected = -l + 2.0 * n.dot(l) * n;
    let specular = reflected.dot(v).max(0.0).powi(32);
    let base = DVec3::new(
        f64::from(color[0]),
        f64::from(color[1]),
        f64::from(color[2]),
    );
    base * (0.3 + 0.7 * diffuse) + DVec3::splat(0.5 * specular)
}

/// A shaded color as the R8G8B8A8_UNORM attachment stores it.
fn unorm8(color: DVec3) -> [u8; 3] {
    color
        .to_array()
        .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
}

/// `mvp` with its depth row replaced by `k' r3 + b' e3` (r3: its w row): what a layer
/// rewriting the pushed matrix to the reversed mapping (k', b') pushes.
fn with_depth_row(mvp: &DMat4, k: f64, b: f64) -> DMat4 {
    let mut m = *mvp;
    let w_row = mvp.row(3);
    for col in 0..4 {
        let e3 = if col == 3 { b } else { 0.0 };
        m.col_mut(col)[2] = k * w_row[col] + e3;
    }
    m
}

/// For every interior pixel of `lit-mvp`'s ground truth (96 x 64): the box, the model-space
/// point it shows and the tangents of that point's face.
fn lit_pixels(scene: &Scene) -> Vec<(usize, DVec3, [DVec3; 2])> {
    let (width, height) = (96u32, 64u32);
    let aspect = f64::from(width) / f64::from(height);
    let (truth, _) = crate::ground_truth::compute(scene, width, height).unwrap();
    let camera = &scene.camera;
    let t = (camera.fov_y / 2.0).tan();
    let view_to_world = camera.view().inverse();
    let mut pixels = Vec::new();
    for (at, &w) in truth.w.iter().enumerate() {
        if !w.is_finite() {
            continue;
        }
        let (px, py) = (at % width as usize, at / width as usize);
        let x = (px as f64 + 0.5) / f64::from(width) * 2.0 - 1.0;
        let y = (py as f64 + 0.5) / f64::from(height) * 2.0 - 1.0;
        let view = DVec3::new(x * t * aspect * w, -y * t * w, -w);
        let n = usize::from(truth.ids[at]);
        let object = &scene.objects[n];
        let p = object
            .model
            .inverse()
            .transform_point3(view_to_world.transform_point3(view));
        // The face: the axis along which the point is farthest out, relative to the box.
        let half = object
            .mesh
            .positions_f64()
            .fold(DVec3::ZERO, |h, q| h.max(q.abs()));
        let axis = (p / half).abs().max_position();
        let tangents = [DVec3::AXES[(axis + 1) % 3], DVec3::AXES[(axis + 2) % 3]];
        pixels.push((n, p, tangents));
    }
    pixels
}

#[test]
fn lit_mvp_pushes_scene_vert_constants_and_culls_back_faces() {
    let scene = lit_mvp();
    let [pipeline] = &scene.plan.pipelines[..] else {
        panic!("{:?}", scene.plan.pipelines);
    };
    assert_eq!(pipeline.program, Program::LitMvp);
    assert!(pipeline.cull_back_faces);
    assert_eq!(Program::LitMvp.push_constant_size(), 80);
    // The layout of scene.vert: the MVP column-major, then the color.
    for object in &scene.objects {
        assert_eq!(
            scene.push_constants(Program::LitMvp, object, ASPECT),
            scene.push_constants(Program::Flat, object, ASPECT),
            "{}",
            object.name
        );
    }
    // Every box is a closed cuboid wound outward: culling keeps the faces the nearest
    // surface is on, so the ground truth is the unculled one.
    let (culled, _) = crate::ground_truth::compute(&scene, 96, 64).unwrap();
    let mut unculled = scene.clone();
    unculled.plan.pipelines[0].cull_back_faces = false;
    let (all, _) = crate::ground_truth::compute(&unculled, 96, 64).unwrap();
    assert_eq!(culled.ids, all.ids);
    let bits = |truth: &crate::ground_truth::GroundTruth| -> Vec<u64> {
        truth.w.iter().map(|w| w.to_bits()).collect()
    };
    assert_eq!(bits(&culled), bits(&all));
}

#[test]
fn lit_mvp_boxes_lie_in_depth_ranges_of_their_own() {
    let scene = lit_mvp();
    let mut ranges: Vec<(f64, f64, &str)> = (0..scene.objects.len())
        .map(|n| {
            let (lo, hi) = clip(&scene, View::Camera, n)
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(lo, hi), c| {
                    (lo.min(c.w), hi.max(c.w))
                });
            (lo, hi, scene.objects[n].name)
        })
        .collect();
    ranges.sort_by(|a, b| a.0.total_cmp(&b.0));
    for pair in ranges.windows(2) {
        let (near, far) = (pair[0], pair[1]);
        assert!(
            far.0 > near.1 * 1.04,
            "{} reaches {:.3}, {} starts at {:.3}",
            near.2,
            near.1,
            far.2,
            far.0
        );
    }
    // The nearest and farthest surfaces, well inside the camera's planes.
    assert!(ranges[0].0 > 30.0 * scene.camera.near, "{ranges:?}");
    assert!(
        ranges.last().unwrap().1 < 0.5 * scene.camera.far,
        "{ranges:?}"
    );
    // Nearest first, so the draw order never decides a pixel.
    let depths: Vec<f64> = scene.objects.iter().map(|o| scene.view_depth(o)).collect();
    assert!(depths.windows(2).all(|w| w[0] < w[1]), "{depths:?}");
}

/// The shading sees the pushed matrix's depth row: with the depth row replaced by the
/// complementary or the infinite reversed one (what a layer rewriting the pushed matrix
/// hands the shader), most interior pixels get another color, while the float32 rounding
/// of the matrix the application pushes changes next to none. So comparing the render
/// through the layer with the native one catches a layer that rewrites the matrix.
#[test]
fn lit_mvp_colors_change_with_the_depth_row() {
    let scene = lit_mvp();
    let aspect = 96.0 / 64.0;
    let (n, f) = (scene.camera.near, scene.camera.far);
    let pixels = lit_pixels(&scene);
    assert!(
        pixels.len() > 96 * 64 / 2,
        "{} interior pixels",
        pixels.len()
    );
    let differing = |change: &dyn Fn(&DMat4) -> DMat4| {
        pixels
            .iter()
            .filter(|&&(object, p, tangents)| {
                let o = &scene.objects[object];
                let mvp = scene.mvp(o, aspect);
                let native = unorm8(lit_shade(&mvp, p, tangents, o.color));
                let changed = unorm8(lit_shade(&change(&mvp), p, tangents, o.color));
                native.iter().zip(changed).any(|(a, b)| a.abs_diff(b) > 1)
            })
            .count() as f64
            / pixels.len() as f64
    };
    let complementary = differing(&|m| with_depth_row(m, -n / (f - n), f * n / (f - n)));
    let infinite = differing(&|m| with_depth_row(m, 0.0, n));
    let rounded = differing(&|m| m.as_mat4().as_dmat4());
    eprintln!(
        "lit-mvp pixels whose color changes by more than 1/255: complementary depth row              {complementary:.3}, infinite {infinite:.3}, float32 rounding {rounded:.4}"
    );
    assert!(
        complementary > 0.5 && infinite > 0.5,
        "{complementary} {infinite}"
    );
    assert!(rounded < 0.01, "{rounded}");
    // The shading is not flat: every box shows several colors, the wall a highlight.
    for (object, o) in scene.objects.iter().enumerate() {
        let mvp = scene.mvp(o, aspect);
        let mut colors: Vec<[u8; 3]> = pixels
            .iter()
            .filter(|p| p.0 == object)
            .map(|&(_, p, tangents)| unorm8(lit_shade(&mvp, p, tangents, o.color)))
            .collect();
        colors.sort_unstable();
        colors.dedup();
        assert!(colors.len() >= 3, "{}: {colors:?}", o.name);
    }
}

/// The scenes the buffer deliveries are meant for (issue #16).
const DELIVERY_SCENES: [&str; 6] = [
    "overlap",
    "sloped-plane",
    "mars-patch",
    "plane-stack",
    "deep-range",
    "far-objects",
];

fn floats(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

#[test]
fn buffer_deliveries_take_the_flat_scenes_and_refuse_special_programs() {
    use crate::plan::Delivery;
    for scene in all() {
        let same = scene.with_delivery(Delivery::Push).unwrap();
        assert_eq!(same, scene, "push changes nothing");
        for delivery in Delivery::ALL.into_iter().skip(1) {
            let program = delivery.program().unwrap();
            match scene.with_delivery(delivery) {
                Ok(taken) => {
                    taken
                        .plan
                        .check(taken.objects.len(), taken.light.is_some())
                        .unwrap_or_else(|e| panic!("{} {delivery:?}: {e}", scene.name));
                    assert!(
                        taken.plan.pipelines.iter().all(|p| p.program == program),
                        "{} {delivery:?}",
                        scene.name
                    );
                    assert_eq!(taken.objects, scene.objects);
                    // The device features of the stage that projects, and nothing else.
                    let needs = taken.plan.needs();
                    assert_eq!(
                        needs.geometry_shader,
                        matches!(
                            delivery,
                            Delivery::UboGeometry
                                | Delivery::UboPassthroughGeometry
                                | Delivery::UboTessellatedGeometry
                                | Delivery::PassthroughGeometryShaderObjects
                                | Delivery::ProjectingGeometryShaderObjects
                                | Delivery::PushGeometry
                        )
                    );
                    assert_eq!(
                        needs.tessellation_shader,
                        matches!(
                            delivery,
                            Delivery::UboTessellation
                                | Delivery::UboInterpolatingTessellation
                                | Delivery::UboProjectingTessellation
                                | Delivery::UboTessellatedGeometry
                                | Delivery::LinkedTessellationShaderObjects
                        )
                    );
                    assert_eq!(
                        needs.shader_object,
                        matches!(
                            delivery,
                            Delivery::ShaderObjects
                                | Delivery::MeshShaderObjects
                                | Delivery::LinkedShaderObjects
                                | Delivery::LinkedTessellationShaderObjects
                                | Delivery::PassthroughGeometryShaderObjects
                                | Delivery::ProjectingGeometryShaderObjects
                        )
                    );
                    assert_eq!(
                        needs.mesh_shader,
                        matches!(delivery, Delivery::Mesh | Delivery::MeshShaderObjects)
                    );
                    // D3D's rasterizer state: the clamp with clipping kept on.
                    assert_eq!(needs.depth_clip_enable, delivery == Delivery::SsboVkd3d);
                    assert!(!needs.depth_clip_enable || needs.depth_clamp);
                    let scene_needs = scene.plan.needs();
                    assert_eq!(
                        crate::plan::Needs {
                            geometry_shader: false,
                            tessellation_shader: false,
                            shader_object: false,
                            mesh_shader: false,
                            depth_clip_enable: false,
                            depth_clamp: scene_needs.depth_clamp,
                            ..needs
                        },
                        scene_needs
                    );
                    // The ground truth comes from the scene, not the delivery.
                    // (w compared bit for bit: NaN where a pixel is not interior.)
                    let bits = |t: &crate::ground_truth::GroundTruth| {
                        (
                            t.ids.clone(),
                            t.w.iter().map(|w| w.to_bits()).collect::<Vec<_>>(),
                        )
                    };
                    if let Ok(truth) = crate::ground_truth::compute_ids(&scene, 48, 36) {
                        let taken_truth = crate::ground_truth::compute_ids(&taken, 48, 36).unwrap();
                        assert!(
                            bits(&taken_truth) == bits(&truth),
                            "{} {delivery:?}: another ground truth",
                            scene.name
                        );
                    }
                }
                Err(why) => {
                    assert!(
                        !DELIVERY_SCENES.contains(&scene.name),
                        "{} refuses {delivery:?}: {why}",
                        scene.name
                    );
                    assert!(
                        why.contains(scene.name) && why.contains(delivery.name()),
                        "{why}"
                    );
                }
            }
        }
    }
    // Special programs, shadow passes and partial pushes are refused, saying why.
    for (scene, why) in [
        (SceneId::ModelViewProjectionPair, "MvpPair program"),
        (SceneId::LitMvp, "LitMvp program"),
        (SceneId::RowMajor, "RowMajor program"),
        (SceneId::FragDepth, "FragDepth program"),
        (SceneId::ShadowMap, "program"),
        (SceneId::PushPartial, "updates push constants"),
    ] {
        let error = scene.build().with_delivery(Delivery::Ubo).unwrap_err();
        assert!(error.contains(why), "{error}");
    }
}

#[test]
fn buffer_blocks_hold_the_delivered_matrices_rounded_once() {
    use crate::plan::{Delivery, Program};
    let aspect = 4.0 / 3.0;
    for name in DELIVERY_SCENES {
        let scene = SceneId::from_str(name, false).unwrap().build();
        for object in &scene.objects {
            let push = floats(&scene.push_constants(Program::Flat, object, aspect));
            let mvp = scene.mvp_in(View::Camera, object, aspect);
            // ssbo: exactly the push constants (the same float32 P * V * M and color).
            let ssbo = floats(&scene.object_block(Program::Ssbo, object, aspect));
            assert_eq!(ssbo, push, "{name}");
            // ubo: P, V and M apart, each rounded from f64; their f64 product is the MVP.
            let ubo = floats(&scene.object_block(Program::Ubo, object, aspect));
            assert_eq!(ubo.len(), 52);
            let [p, v, m] = scene.separate_matrices(object, aspect);
            for (k, matrix) in [p, v, m].iter().enumerate() {
                assert_eq!(
                    ubo[16 * k..16 * (k + 1)],
                    matrix.as_mat4().to_cols_array(),
                    "{name}"
                );
            }
            assert_eq!(ubo[48..], object.color);
            let largest = mvp.abs().to_cols_array().into_iter().fold(0.0, f64::max);
            assert!((p * v * m).abs_diff_eq(mvp, 1e-12 * largest), "{name}");
            assert_eq!(
                scene.pushed_projection(Program::Ubo, object, aspect),
                p.as_mat4().to_cols_array()
            );
            // ubo-dynamic: the shared frame's P * V and the object's model.
            let model = floats(&scene.object_block(Program::UboDynamic, object, aspect));
            let frame = floats(&scene.frame_block(aspect));
            let (inner, outer) = scene.model_split(View::Camera, object, aspect);
            assert_eq!(frame, outer.as_mat4().to_cols_array(), "{name}");
            assert_eq!(model[..16], inner.as_mat4().to_cols_array());
            assert_eq!(model[16..], object.color);
            assert_eq!(
                scene.pushed_projection(Program::UboDynamic, object, aspect),
                outer.as_mat4().to_cols_array()
            );
            assert_eq!(
                scene.matrix_stages(Program::Ubo, View::Camera, object, aspect),
                vec![p, v, m]
            );
        }
        // Push constants are not used by the buffer deliveries.
        let taken = scene.with_delivery(Delivery::Ubo).unwrap();
        assert_eq!(taken.plan.pipelines[0].program.push_constant_size(), 0);
        assert!(scene
            .push_constants(Program::Ubo, &scene.objects[0], aspect)
            .is_empty());
    }
}

/// `depth-mips`: the overlap scene into level 0, each lower level blitted from the one above
/// it (TRANSFER_SRC into TRANSFER_DST) and put into SHADER_READ_ONLY_OPTIMAL by a barrier of
/// its own, once nothing reads it as a transfer source any more; `depth-layers`: layer 1
/// drawn depth-only with the near cube moved, both layers sampled after one barrier.
#[test]
fn depth_mips_and_layers_render_and_sample_every_level_and_layer() {
    let scene = depth_mips();
    let into_sampled: Vec<u32> = scene
        .plan
        .steps
        .iter()
        .filter_map(|step| match step {
            Step::DepthLevelLayout {
                level,
                to: DepthLayout::Sampled,
                ..
            } => Some(*level),
            _ => None,
        })
        .collect();
    assert_eq!(into_sampled, [0, 1, 2]);
    let blits: Vec<u32> = scene
        .plan
        .steps
        .iter()
        .filter_map(|step| match step {
            Step::BlitDepthLevel { level } => Some(*level),
            _ => None,
        })
        .collect();
    assert_eq!(blits, [1, 2]);
    assert_eq!(
        drawn_in(&scene, Target::Main).len(),
        overlap().objects.len()
    );

    let scene = depth_layers();
    let layer = Target::DepthSlice { level: 0, layer: 1 };
    let second: Vec<&str> = drawn_in(&scene, layer)
        .into_iter()
        .map(|n| scene.objects[n].name)
        .collect();
    assert!(second.contains(&"moved near cube") && !second.contains(&"near cube"));
    assert_eq!(second.len(), overlap().objects.len());
    // The moved cube stands right of the image's center, the near cube left of it, both
    // reaching into the rows layer 1's band shades (NDC y in [0, 0.5]).
    let (moved_lo, moved_hi) = screen_box(&scene, "moved near cube");
    let (near_lo, near_hi) = screen_box(&scene, "near cube");
    assert!(moved_lo[0] > 0.0 && near_hi[0] < 0.0);
    assert!(moved_hi[1] > 0.0 && near_hi[1] > 0.0);
    assert!(moved_lo[1] < 0.5 && near_lo[1] < 0.5);
}
