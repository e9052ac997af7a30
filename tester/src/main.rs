//! `revz-tester`: an ordinary headless Vulkan application that renders a known scene offscreen
//! (standard depth: near 0, far 1) and writes what it rendered to files. It knows nothing of
//! the revz layer; the layer, when injected, changes what it renders. Each scene (`scenes`)
//! exercises depth state a reversed-depth layer must handle: compare ops, clear values, depth
//! bias and bounds, viewport depth ranges, stencil, secondaries, subpasses, dynamic rendering,
//! pipeline libraries, a sampled shadow map, and the ways applications hand their projection
//! to the shader (push constant layouts, partial updates, OpenGL depth, already reversed,
//! threads). Where the nearest surface wins, it also writes the computed ground truth
//! (`ground_truth`).
//!
//! This file owns the command line and the orchestration only; see the modules for the rest.
//!
//! Exit codes: 0 = rendered, no counted validation message; 1 = error; 2 = rendered (files
//! written) but the validation layer reported messages.

// The bench summary's `json!` rows are deeper than serde_json's default macro recursion.
#![recursion_limit = "256"]

mod accuracy;
mod bench;
mod demo;
mod gl;
mod gpu;
mod ground_truth;
mod pipeline;
mod plan;
mod precision;
mod profile;
mod readback;
mod render;
mod scene;
mod scenes;
mod shaders;
mod stress;
mod target;
mod transfers;
mod variants;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{anyhow, bail, Context, Result};
use clap::{Parser, Subcommand};

use crate::gpu::{Features, Gpu, GpuOptions};
use crate::plan::{Delivery, ResolveMode};
use crate::readback::{resolve_mode_name, DepthStats, MultisampleReport, Readback, RenderReport};
use crate::render::{Renderer, SceneBuffers};
use crate::scene::SceneId;
use crate::target::{DepthFormat, TargetOptions, Targets};

/// Renders a known scene offscreen with Vulkan and writes color.png, depth.png, depth.f32 and
/// render.json (see `--scene` for the scenes), and for scenes where the nearest surface wins
/// the computed ground truth, expected-w.f64 and expected-id.u16.
#[derive(Debug, Parser)]
#[command(
    name = "revz-tester",
    version,
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,

    #[command(flatten)]
    render: RenderArgs,
}

/// What else the tester does, beyond rendering one scene (the default).
#[derive(Debug, Subcommand)]
enum Command {
    /// What revz does, in about a minute: the hard cases without and with revz against ground
    /// truth, the wrong-pixel table, a labelled side-by-side picture, and a quick cost figure.
    Demo(demo::DemoArgs),
    /// Accuracy report: every hard-case scene in every mode and depth format against ground
    /// truth, the precision model beside it (report.json, report.md, images, plots).
    Report(accuracy::ReportArgs),
    /// Conformance for CI: every scene, mode and depth format against ground truth with a
    /// stated bound each; exits non-zero on any failure; writes JUnit XML and JSON.
    Conformance(accuracy::ConformanceArgs),
    /// Benchmark: the layer's cost per frame, per pipeline and per intercepted call in every
    /// mode, as ratios against no layer measured in one run.
    Bench(bench::BenchArgs),
    /// Multi-threaded recording stress: threads recording secondaries into one primary, for
    /// many frames; every frame must equal the first (writes a render and stress.json).
    StressThreads(stress::StressArgs),
    /// OpenGL: a scene drawn by a small GL program (EGL, headless), on llvmpipe or through
    /// Zink on lavapipe (`--zink`, `--revz MODE`), measured against the ground truth.
    GlRender(gl::GlRenderArgs),
    /// revz's depth profile (`REVZ_REPORT`) as tables, and a bar chart of the draws per path
    /// per frame (`--png`).
    Profile(profile::ProfileArgs),
    /// Copies and blits of depth images that are only ever copied (2D and 3D, every aspect,
    /// layouts apart), as a conformance suite's copy groups make them; writes the
    /// destination's depth and stencil for comparison with and without revz.
    Transfers(transfers::TransferArgs),
    /// The scenes `--scene` takes, one per line (for test drivers).
    Scenes,
}

/// Renders one scene (the default command).
#[derive(Debug, clap::Args)]
struct RenderArgs {
    /// Render on the first device whose name contains NAME (case-insensitive). Default: the
    /// first device whose name contains "llvmpipe" (lavapipe), else the first device.
    #[arg(long, value_name = "NAME")]
    device: Option<String>,

    /// Format of the depth attachment.
    #[arg(long, value_enum, value_name = "FORMAT", default_value = "d32")]
    depth_format: DepthFormat,

    /// Scene to render.
    #[arg(long, value_enum, default_value = "overlap")]
    scene: SceneId,

    /// How the scene hands its matrices to the vertex shader: push constants (the scenes'
    /// own), `ubo` (P, V and M apart in a dynamic uniform buffer block per object),
    /// `ubo-dynamic` (P * V in a uniform buffer, the model matrix in a dynamic one) or `ssbo`
    /// (P * V * M per object in a storage buffer, indexed by the instance index). The buffer
    /// deliveries replace the flat push-constant program; scenes with other programs, shadow
    /// passes or partial push updates refuse them.
    #[arg(long, value_enum, value_name = "HOW", default_value = "push")]
    delivery: Delivery,

    /// How the multisampled scenes (msaa-resolve, msaa-resolve-dynamic) resolve depth into
    /// the depth image read back [default: sample-zero]. The device must support the mode
    /// (VkPhysicalDeviceDepthStencilResolveProperties; lavapipe: sample-zero and average).
    /// Other scenes resolve nothing and refuse it.
    #[arg(long, value_enum, value_name = "MODE")]
    depth_resolve: Option<ResolveMode>,

    /// Width of the render in pixels.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: u32,

    /// Height of the render in pixels.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: u32,

    /// Enable VK_LAYER_KHRONOS_validation and count its messages (exit code 2 if any).
    #[arg(long)]
    validation: bool,

    /// With --validation: enable synchronization validation too.
    #[arg(long, requires = "validation")]
    sync_validation: bool,

    /// How the depth image reaches the host: `direct` (one copy into the host buffer),
    /// `image` (through a second depth image only copied: revz reverses it by default),
    /// `native-image` (through a second depth image that may be sampled: revz keeps it
    /// native) or `buffer` (into a device buffer, back into a second depth image, then to the
    /// host). Every route must read back the same depth.
    #[arg(long, value_enum, value_name = "ROUTE", default_value = "direct")]
    depth_route: readback::DepthRoute,

    /// Texels of padding after each row of the depth read-back buffer (bufferRowLength =
    /// width + N); the padding must be left as it was.
    #[arg(long, value_name = "N", default_value_t = 0)]
    depth_row_padding: u32,

    /// Render the scene this many times (recording it again each time), writing out the
    /// last: what a layer learns in one frame (infinite mode's n / f) is in force from the
    /// first command of the next.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=16))]
    frames: u32,

    /// Record the depth read-back with the `*2` copy commands (Vulkan 1.3).
    #[arg(long)]
    copy2: bool,

    /// The image-to-image copies of `--depth-route image|native-image` copy every aspect of a
    /// depth-stencil format (the stencil too), not the depth aspect alone.
    #[arg(long)]
    copy_all_aspects: bool,

    /// Do not read the depth image back: it is created without TRANSFER_SRC usage, and
    /// depth.png / depth.f32 are not written (render.json says "depth_readback": false).
    #[arg(long)]
    no_depth_readback: bool,

    /// Ask for at most this Vulkan version, as an older application would. Scenes that need
    /// a later core version (dynamic rendering and dynamic compare ops 1.3, multisampled depth
    /// resolves 1.2) are refused below it.
    #[arg(long, value_name = "VERSION", value_parser = ["1.0", "1.1", "1.2", "1.3"])]
    vulkan: Option<String>,

    /// Bind the depth pyramid's compute pipeline and descriptors at the start of the
    /// recording, with a descriptor set, a descriptor buffer (`VK_EXT_descriptor_buffer`,
    /// Vulkan 1.3: lavapipe has it from Mesa 23.x on), push descriptors (written, or through
    /// an update template; `VK_KHR_push_descriptor`), the set with a compute shader object in
    /// the pipeline's place (`VK_EXT_shader_object`), or the set or descriptor buffer offsets
    /// bound by `VK_KHR_maintenance6`'s commands (`sets2`, `buffer2`), so that its dispatch
    /// after the passes binds nothing: what the layer's conversions in between disturb, it
    /// must bind again. Only depth-reads builds a depth pyramid.
    #[arg(long, value_enum, value_name = "DESCRIPTORS")]
    bind_tiles_first: Option<plan::TileDescriptors>,

    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR", required = true)]
    out: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            // --help and --version are not errors; every usage error is exit code 1 (2 means
            // "rendered with validation messages").
            return if e.use_stderr() {
                ExitCode::from(1)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    let outcome = match &cli.command {
        Some(Command::Demo(args)) => return report_exit(demo::run(args)),
        Some(Command::Report(args)) => return report_exit(accuracy::report(args)),
        Some(Command::Conformance(args)) => return report_exit(accuracy::conformance(args)),
        Some(Command::Bench(args)) => return report_exit(bench::run(args)),
        Some(Command::StressThreads(args)) => return report_exit(stress::run(args)),
        Some(Command::GlRender(args)) => return report_exit(gl::run(args)),
        Some(Command::Profile(args)) => return report_exit(profile::run(args)),
        Some(Command::Transfers(args)) => return report_exit(transfers::run(args)),
        Some(Command::Scenes) => {
            for entry in scenes::CATALOG {
                println!("{}", entry.name);
            }
            return ExitCode::SUCCESS;
        }
        None => run(&cli.render),
    };
    if cli.command.is_none() {
        profile::print_own_summary();
    }
    match outcome {
        Ok(0) => ExitCode::SUCCESS,
        Ok(messages) => {
            eprintln!("revz-tester: {messages} validation message(s) reported");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("revz-tester: error: {e:#}");
            ExitCode::from(1)
        }
    }
}

/// The exit code of a subcommand: its own, or 1 with the error printed.
fn report_exit(result: Result<ExitCode>) -> ExitCode {
    result.unwrap_or_else(|e| {
        eprintln!("revz-tester: error: {e:#}");
        ExitCode::from(1)
    })
}

/// Renders and writes the outputs; returns the number of counted validation messages.
fn run(cli: &RenderArgs) -> Result<u32> {
    let out = cli
        .out
        .as_deref()
        .context("--out is required when rendering a scene")?;
    let mut scene = cli
        .scene
        .build()
        .with_delivery(cli.delivery)
        .map_err(anyhow::Error::msg)?;
    if let Some(descriptors) = cli.bind_tiles_first {
        scene.plan = scene
            .plan
            .with_tiles_bound_first(descriptors)
            .map_err(|e| anyhow!("scene '{}': {e}", scene.name))?;
    }
    let depth_resolve = cli.depth_resolve.unwrap_or(ResolveMode::SampleZero);
    if !scene.plan.set_depth_resolve(depth_resolve) && cli.depth_resolve.is_some() {
        bail!(
            "scene '{}' has no multisampled pass: --depth-resolve applies to msaa-resolve and \
             msaa-resolve-dynamic",
            scene.name
        );
    }
    let needs = scene.plan.needs();
    if needs.stencil && !cli.depth_format.has_stencil() {
        bail!(
            "scene '{}' needs a depth format with a stencil aspect (d24-s8 or d32-s8), not {}",
            scene.name,
            cli.depth_format.vk_name()
        );
    }
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;

    let gpu = Gpu::new(&GpuOptions {
        device: cli.device.clone(),
        validation: cli.validation,
        sync_validation: cli.sync_validation,
        max_api_version: cli.vulkan.as_deref().map(|v| match v {
            "1.0" => ash::vk::API_VERSION_1_0,
            "1.1" => ash::vk::API_VERSION_1_1,
            "1.2" => ash::vk::API_VERSION_1_2,
            _ => ash::vk::API_VERSION_1_3,
        }),
        features: Features {
            dynamic_rendering: needs.dynamic_rendering,
            dynamic_compare_op: needs.dynamic_compare_op,
            depth_stencil_resolve: needs.multisample.is_some(),
            separate_depth_stencil_layouts: false,
            depth_bounds: needs.depth_bounds,
            depth_bias_clamp: needs.depth_bias_clamp,
            depth_clip_control: needs.depth_clip_control,
            graphics_pipeline_library: needs.graphics_pipeline_library,
            depth_range_unrestricted: needs.depth_range_unrestricted,
            depth_clamp: needs.depth_clamp,
            depth_clip_enable: needs.depth_clip_enable,
            geometry_shader: needs.geometry_shader,
            tessellation_shader: needs.tessellation_shader,
            shader_object: needs.shader_object,
            mesh_shader: needs.mesh_shader,
            descriptor_buffer: needs.descriptor_buffer,
            maintenance6: needs.maintenance6,
            dynamic_rendering_local_read: needs.dynamic_rendering_local_read,
            multiview: needs.views > 0,
            // Optional: a post pass pushes its descriptors where the device can.
            push_descriptor: needs.sampled_depth,
        },
    })?;
    say(&format!(
        "device: {} ({}, Vulkan {})",
        gpu.info.name,
        gpu.info.driver(),
        gpu.info.api_version_string()
    ));
    let device_info = gpu.info.clone();
    let lacks = |what: &str| format!("scene '{}': device lacks {what}", scene.name);
    if needs.dynamic_compare_op && !gpu.supported.dynamic_compare_op {
        bail!(lacks(
            "a dynamic depth compare op (Vulkan 1.3 or VK_EXT_extended_dynamic_state)"
        ));
    }
    if needs.dynamic_rendering && !gpu.supported.dynamic_rendering {
        bail!(lacks(
            "dynamicRendering (Vulkan 1.3 or VK_KHR_dynamic_rendering)"
        ));
    }
    if needs.depth_bounds && !gpu.supported.depth_bounds {
        bail!(lacks("depthBounds"));
    }
    if needs.depth_clip_control && !gpu.supported.depth_clip_control {
        bail!(lacks("depthClipControl (VK_EXT_depth_clip_control)"));
    }
    if needs.depth_range_unrestricted && !gpu.supported.depth_range_unrestricted {
        bail!(lacks("VK_EXT_depth_range_unrestricted"));
    }
    if needs.depth_clamp && !gpu.supported.depth_clamp {
        bail!(lacks("depthClamp"));
    }
    if needs.depth_clip_enable && !gpu.supported.depth_clip_enable {
        bail!(lacks("depthClipEnable (VK_EXT_depth_clip_enable)"));
    }
    if needs.geometry_shader && !gpu.supported.geometry_shader {
        bail!(lacks("geometryShader"));
    }
    if needs.tessellation_shader && !gpu.supported.tessellation_shader {
        bail!(lacks("tessellationShader"));
    }
    if needs.shader_object && !gpu.supported.shader_object {
        bail!(lacks(
            "shaderObject (VK_EXT_shader_object on Vulkan 1.3; lavapipe has it from Mesa 23.1 \
             on: `cargo xtask setup` extracts a newer lavapipe into target/lavapipe-backports)"
        ));
    }
    if needs.graphics_pipeline_library && !gpu.supported.graphics_pipeline_library {
        bail!(lacks(
            "graphicsPipelineLibrary (VK_EXT_graphics_pipeline_library with \
             VK_KHR_pipeline_library)"
        ));
    }
    if needs.mesh_shader && !gpu.supported.mesh_shader {
        bail!(lacks(
            "meshShader (VK_EXT_mesh_shader on Vulkan 1.3; lavapipe has it from Mesa 23.3 on: \
             `cargo xtask setup` extracts a newer lavapipe into target/lavapipe-backports)"
        ));
    }
    let pushes_tiles = matches!(
        needs.tile_descriptors,
        Some(plan::TileDescriptors::Push | plan::TileDescriptors::PushTemplate)
    );
    if pushes_tiles && !gpu.enabled.push_descriptor {
        bail!(lacks("VK_KHR_push_descriptor"));
    }
    if needs.views > 0 && !gpu.supported.multiview {
        bail!(lacks("multiview (Vulkan 1.1 or VK_KHR_multiview)"));
    }
    if needs.maintenance6 && !gpu.supported.maintenance6 {
        bail!(lacks("maintenance6 (VK_KHR_maintenance6 on Vulkan 1.3)"));
    }
    if needs.dynamic_rendering_local_read && !gpu.supported.dynamic_rendering_local_read {
        bail!(lacks(
            "dynamicRenderingLocalRead (VK_KHR_dynamic_rendering_local_read on Vulkan 1.3: \
             Mesa 25.0's lavapipe has it, 22.3's does not; `cargo xtask setup` extracts a \
             newer lavapipe into target/lavapipe-backports)"
        ));
    }
    if needs.descriptor_buffer && !gpu.supported.descriptor_buffer {
        bail!(lacks(
            "descriptorBuffer with bufferDeviceAddress (VK_EXT_descriptor_buffer on Vulkan 1.3: \
             `cargo xtask setup` extracts a newer lavapipe into target/lavapipe-backports)"
        ));
    }
    let features = gpu.enabled.names();
    let validation_skipped = gpu.validation_skipped().map(str::to_owned);
    if let Some(why) = &validation_skipped {
        say(&format!("validation: {why}"));
    }

    // Every Vulkan object lives inside this block and is destroyed when it ends (in reverse
    // order of creation); only host data leaves it.
    let depth_readback = !cli.no_depth_readback;
    let frame = {
        let options = TargetOptions {
            depth_readback,
            clear_depth_image: needs.clear_depth_image,
            shadow_map: needs.shadow_map.then(|| {
                scene
                    .light
                    .as_ref()
                    .map_or(target::SHADOW_MAP_FORMAT, |light| light.map_format)
            }),
            sampled_depth: needs.sampled_depth,
            input_depth: needs.input_depth,
            multisample: needs.multisample,
            depth_subresources: needs.depth_subresources,
            depth_blits: needs.depth_blits,
            views: needs.views,
        };
        let targets = Targets::new(&gpu, cli.width, cli.height, cli.depth_format, options)?;
        let buffers = SceneBuffers::upload(&gpu, &scene)?;
        if cli.copy2 && gpu.api_version() < ash::vk::API_VERSION_1_3 {
            bail!("--copy2 needs Vulkan 1.3 (the *2 copy commands)");
        }
        let options = readback::DepthReadback {
            route: cli.depth_route,
            row_padding: cli.depth_row_padding,
            copy2: cli.copy2,
            all_aspects: cli.copy_all_aspects,
        };
        let readback = Readback::new(&gpu, &targets, depth_readback, options)?;
        let renderer = Renderer::new(&gpu, &targets, &scene)?;
        for _ in 0..cli.frames {
            renderer.render(&gpu, &scene, &buffers, &targets, &readback)?;
        }
        let multisample = targets.multisampled.as_ref().map(|ms| MultisampleReport {
            samples: ms.samples.as_raw(),
            depth_resolve: resolve_mode_name(ms.resolve.depth),
            stencil_resolve: resolve_mode_name(ms.resolve.stencil),
        });
        let recorded = recorded(&scene, &renderer, &targets, cli.frames);
        (readback.frames()?, multisample, recorded)
    };
    let (frames, multisample, recorded) = frame;
    let clear_depth = scene.plan.main_clear_depth();
    let views = frames
        .iter()
        .enumerate()
        .map(|(view, frame)| write_view(out, &scene, view, frame, clear_depth))
        .collect::<Result<Vec<_>>>()?;

    // Destroy the device and the instance before counting, so that what validation reports
    // at vkDestroyDevice / vkDestroyInstance (leaks) is counted too.
    let log = gpu.validation_log();
    drop(gpu);
    let messages = log.count();

    let frame = &frames[0];
    let report = RenderReport {
        device: device_info.name.clone(),
        driver: device_info.driver(),
        depth_format: cli.depth_format.vk_name(),
        scene: cli.scene.name(),
        delivery: cli.delivery.name(),
        width: frame.width,
        height: frame.height,
        views: views.len(),
        view: 0,
        validation_messages: messages,
        validation_skipped,
        features,
        depth_readback,
        stencil_readback: false,
        clear_depth,
        depth_min: None,
        depth_max: None,
        covered_pixels: None,
        multisample,
        ground_truth: None,
        recorded,
    };
    for (view, written) in views.into_iter().enumerate() {
        let report = RenderReport {
            view,
            depth_min: written.stats.and_then(|s| s.min),
            depth_max: written.stats.and_then(|s| s.max),
            covered_pixels: written.stats.map(|s| s.covered),
            ground_truth: written.ground_truth,
            ..report.clone()
        };
        print_wrote(&readback::write_report(&written.dir, &report)?);
    }
    Ok(messages)
}

/// What [`write_view`] wrote of one view, for its `render.json`.
struct ViewOutput {
    /// The view's directory ([`readback::view_dir`]).
    dir: PathBuf,
    /// Its depth statistics (None if depth was not read back).
    stats: Option<DepthStats>,
    /// Its ground truth (None for scenes where something else than the nearest surface
    /// decides what shows).
    ground_truth: Option<ground_truth::GroundTruthReport>,
}

/// Writes view `view`'s images (`frame`, whose uncovered pixels hold `clear_depth`) and its
/// ground truth, computed from the view's own camera ([`crate::scene::Scene::seen_from`]),
/// into its directory ([`readback::view_dir`]).
fn write_view(
    out: &Path,
    scene: &crate::scene::Scene,
    view: usize,
    frame: &readback::Frame,
    clear_depth: f32,
) -> Result<ViewOutput> {
    let dir = readback::view_dir(out, view);
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("cannot create output directory {}", dir.display()))?;
    for path in readback::write_images(&dir, frame, clear_depth)? {
        print_wrote(&path);
    }
    // Pure computation, no Vulkan: scenes where something else than the nearest surface
    // decides what shows have none.
    let seen = scene.seen_from(view);
    let ground_truth = match ground_truth::compute(&seen, frame.width, frame.height) {
        Ok((truth, report)) => {
            for (name, bytes) in [
                (ground_truth::W_FILE, truth.w_bytes()),
                (ground_truth::ID_FILE, truth.id_bytes()),
            ] {
                let path = dir.join(name);
                std::fs::write(&path, bytes)
                    .with_context(|| format!("cannot write {}", path.display()))?;
                print_wrote(&path);
            }
            Some(report)
        }
        Err(_) => None,
    };
    let stats = frame
        .depth
        .as_ref()
        .map(|depth| DepthStats::of(depth, clear_depth));
    Ok(ViewOutput {
        dir,
        stats,
        ground_truth,
    })
}

/// `render.json`'s `recorded`: the depth images and the draws of one frame of `plan`.
fn recorded(
    scene: &crate::scene::Scene,
    renderer: &Renderer<'_>,
    targets: &Targets<'_>,
    frames: u32,
) -> readback::RecordedReport {
    use crate::plan::Target;
    use readback::{RecordedDraws, RecordedImage};
    let plan = &scene.plan;
    let handle = |raw: u64| format!("{raw:#x}");
    let image = |role, a: &crate::target::Attachment<'_>| RecordedImage {
        role,
        handle: handle(ash::vk::Handle::as_raw(a.image)),
        format: format!("{:?}", a.format),
        usage: a.usage.as_raw(),
        samples: a.samples.as_raw(),
        width: a.extent.width,
        height: a.extent.height,
    };
    let mut depth_images = vec![image("main", &targets.depth)];
    depth_images.extend(targets.shadow.as_ref().map(|a| image("shadow", a)));
    depth_images.extend(
        targets
            .multisampled
            .as_ref()
            .map(|ms| image("multisampled", &ms.depth)),
    );
    let draws = plan
        .draw_census()
        .into_iter()
        .map(|(index, target, multisampled, draws)| {
            let spec = &plan.pipelines[index];
            RecordedDraws {
                pipeline: spec.name,
                handle: handle(ash::vk::Handle::as_raw(renderer.pipelines()[index])),
                program: format!("{:?}", spec.program),
                depth_test: spec.depth_test != crate::plan::DepthTest::Off,
                viewport_depth: match spec.viewport {
                    crate::plan::Viewport::Static {
                        min_depth,
                        max_depth,
                    } => Some([min_depth, max_depth]),
                    crate::plan::Viewport::Dynamic => None,
                },
                depth_clamp: spec.depth_clamp,
                image: match (target, multisampled) {
                    (Target::Shadow, _) => "shadow",
                    (Target::Main, true) => "multisampled",
                    // A depth slice is another mip level or array layer of the main image.
                    (Target::Main | Target::SoftParticles | Target::DepthSlice { .. }, false) => {
                        "main"
                    }
                    // The census counts no draw of a pass without a depth attachment.
                    (Target::Post, _)
                    | (Target::SoftParticles | Target::DepthSlice { .. }, true) => "none",
                },
                draws,
            }
        })
        .collect();
    let aspect = f64::from(targets.extent.width) / f64::from(targets.extent.height);
    let matrix_near = scene
        .objects
        .iter()
        .map(|object| {
            let pushed = scene
                .mvp_in(crate::scene::View::Camera, object, aspect)
                .as_mat4()
                .as_dmat4();
            near_of_clip_matrix(&pushed, scene.camera.projection.negative_one_to_one())
        })
        .collect();
    readback::RecordedReport {
        frames,
        depth_images,
        draws,
        matrix_near,
    }
}

/// The near plane of a clip matrix whose depth row lies on its w row, z = k w + B: where
/// z / w reaches the near end of the depth range (0, or -1 for `negative_one_to_one`), in f64.
/// `None` where w does not vary with position or the line is not a perspective one.
fn near_of_clip_matrix(m: &glam::DMat4, negative_one_to_one: bool) -> Option<f64> {
    let (depth, w) = (m.row(2), m.row(3));
    let w_xyz = w.truncate();
    let length_squared = w_xyz.length_squared();
    if length_squared == 0.0 {
        return None;
    }
    let k = depth.truncate().dot(w_xyz) / length_squared;
    let b = depth.w - k * w.w;
    let near = if negative_one_to_one {
        -b / (k + 1.0)
    } else {
        -b / k
    };
    (near.is_finite() && near > 0.0 && b != 0.0).then_some(near)
}

fn print_wrote(path: &Path) {
    say(&format!("wrote: {}", path.display()));
}

/// Prints a line to stdout; a closed stdout (`revz-tester ... | head -1`) is not worth a panic
/// or an error: the files are what matters.
fn say(line: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stdout().lock(), "{line}");
}
