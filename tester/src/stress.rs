//! `revz-tester stress-threads`: multi-threaded recording, many frames. Each frame, `--threads`
//! threads (default 8) record at once, each into a secondary command buffer of a command pool
//! it creates for that frame (Vulkan wants external synchronization per pool), continuing the
//! one render pass of the primary: the even-numbered threads inherit the render pass and the
//! framebuffer, the odd-numbered ones the render pass only (no framebuffer: a layer then knows
//! just the depth format). Every thread binds the pipeline, sets the viewport and pushes each of
//! its objects' matrices before drawing it (a grid of cubes on a ground quad, one camera, LESS).
//! One primary executes the secondaries; the frame is submitted, waited for and read back.
//!
//! Every frame from the second on must be bit-identical to the second (color and depth): a race
//! in what a layer keeps per command buffer would show as a frame that differs. The first frame
//! is a warm-up: a layer may learn across frames (revz learns each camera's best-conditioned
//! matrix, so the first frame's recordings, all begun before any ended, may start from a worse
//! one). The reference frame is written as
//! the default command writes a render (color.png, depth.png, depth.f32, render.json with the
//! ground truth, expected-w.f64, expected-id.u16), plus `stress.json` (threads, frames, time,
//! the frames that differed). Exit codes as for rendering: 0, 1 (error, or a frame differed),
//! 2 (validation messages).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use glam::DVec3;
use serde::Serialize;

use crate::gpu::{Features, Gpu, GpuOptions};
use crate::ground_truth;
use crate::plan::{PassSpec, PipelineSpec, Plan, Recording, Step, Viewport};
use crate::readback::{self, DepthStats, Frame, Readback, RenderReport};
use crate::render::{Renderer, SceneBuffers};
use crate::scene::{grounded_cube, overlap_camera, rgb8, Mesh, Object, Scene, Space};
use crate::target::{DepthFormat, TargetOptions, Targets};

/// The scene's name in `render.json`.
const SCENE: &str = "threads-stress";

/// Renders the threads stress scene for many frames (see the module documentation).
#[derive(Debug, clap::Args)]
pub struct StressArgs {
    /// Render on the first device whose name contains NAME (default: lavapipe, else the first).
    #[arg(long, value_name = "NAME")]
    device: Option<String>,

    /// Format of the depth attachment.
    #[arg(long, value_enum, value_name = "FORMAT", default_value = "d32")]
    depth_format: DepthFormat,

    /// Recording threads (one secondary command buffer each, per frame).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=64))]
    threads: u32,

    /// Frames rendered (each recorded from scratch by every thread).
    #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,

    /// Width and height of the render in pixels.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=4096))]
    size: u32,

    /// Enable VK_LAYER_KHRONOS_validation and count its messages (exit code 2 if any).
    #[arg(long)]
    validation: bool,

    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

/// `stress.json`.
#[derive(Debug, Serialize)]
struct StressReport {
    threads: u32,
    frames: u32,
    /// Secondary command buffers recorded per frame (one per thread).
    secondaries_per_frame: u32,
    /// Of which inherit no framebuffer.
    secondaries_without_framebuffer: u32,
    draws_per_frame: usize,
    /// Wall time of all frames (recording, submission, wait, read-back).
    seconds: f64,
    /// The frames (0-based) whose color or depth differ from frame 0's.
    differing_frames: Vec<u32>,
}

/// Cubes in a grid on the ground, 8 per row, 4 rows, of distinct colors. They do not touch
/// one another (a turned cube reaches at most 0.15 * sqrt(2) = 0.21 from its center, the
/// spacing is at least 0.45): no intersection lines between cubes, whose depth ties would
/// depend on each matrix's float32 rounding rather than on the recording.
fn grid_objects() -> Vec<Object> {
    let mut objects = vec![Object {
        name: "ground",
        mesh: Mesh::quad(10.0, 10.0),
        model: glam::DMat4::from_translation(DVec3::new(0.0, 0.0, -4.0)),
        color: rgb8(150, 60, 170),
        space: Space::World,
    }];
    for row in 0..4u8 {
        for column in 0..8u8 {
            let name: &'static str = Box::leak(format!("cube {row}.{column}").into_boxed_str());
            let x = (f64::from(column) - 3.5) * (0.45 + 0.12 * f64::from(row));
            let z = 1.5 - 1.6 * f64::from(row);
            let yaw = 0.2 * f64::from(row * 8 + column);
            let color = rgb8(30 + 30 * column, 40 + 60 * row, 230 - 25 * column);
            objects.push(grounded_cube(name, 0.15, x, z, yaw, color));
        }
    }
    objects
}

/// The scene: the grid drawn by `threads` threads (objects dealt round-robin, nearest first),
/// in one render pass cleared to 1.0.
fn scene(threads: usize) -> Scene {
    let mut scene = Scene::new(SCENE, overlap_camera(), grid_objects());
    let pipeline = PipelineSpec {
        viewport: Viewport::Dynamic,
        ..PipelineSpec::standard("dynamic viewport", 0)
    };
    let lists = (0..threads)
        .map(|thread| {
            let mut steps = vec![
                Step::Bind(0),
                Step::SetViewport {
                    min_depth: 0.0,
                    max_depth: 1.0,
                },
            ];
            steps.extend(
                (0..scene.objects.len())
                    .skip(thread)
                    .step_by(threads)
                    .map(Step::Draw),
            );
            steps
        })
        .collect();
    scene.plan = Plan {
        passes: vec![PassSpec::clear(1.0)],
        pipelines: vec![pipeline],
        steps: vec![
            Step::BeginPass(0),
            Step::ExecuteSecondaries(lists, Recording::ThreadPerSecondaryOddWithoutFramebuffer),
            Step::EndPass,
        ],
    };
    scene
}

fn say(line: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stdout().lock(), "{line}");
}

/// Whether two frames are bit-identical.
fn same(a: &Frame, b: &Frame) -> bool {
    let bits = |frame: &Frame| {
        frame
            .depth
            .as_ref()
            .map(|d| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>())
    };
    a.rgba == b.rgba && bits(a) == bits(b)
}

/// Runs the subcommand.
pub fn run(args: &StressArgs) -> Result<ExitCode> {
    let scene = scene(args.threads as usize);
    let needs = scene.plan.needs();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let gpu = Gpu::new(&GpuOptions {
        device: args.device.clone(),
        validation: args.validation,
        sync_validation: false,
        max_api_version: None,
        features: Features::default(),
    })?;
    say(&format!(
        "device: {} ({}, Vulkan {})",
        gpu.info.name,
        gpu.info.driver(),
        gpu.info.api_version_string()
    ));
    let device_info = gpu.info.clone();
    let (first, seconds, differing) = {
        let options = TargetOptions {
            depth_readback: true,
            clear_depth_image: needs.clear_depth_image,
            shadow_map: None,
            sampled_depth: false,
            input_depth: false,
            multisample: None,
            depth_subresources: Default::default(),
            depth_blits: false,
            views: 0,
        };
        let targets = Targets::new(&gpu, args.size, args.size, args.depth_format, options)?;
        let buffers = SceneBuffers::upload(&gpu, &scene)?;
        let readback = Readback::new(&gpu, &targets, true, Default::default())?;
        let renderer = Renderer::new(&gpu, &targets, &scene)?;
        let start = Instant::now();
        let mut first: Option<Frame> = None;
        let mut differing = Vec::new();
        // The warm-up frame (see the module docs) is rendered but not compared.
        let reference = u32::from(args.frames > 1);
        for frame in 0..args.frames {
            if frame > 0 {
                renderer.next_frame()?;
            }
            renderer
                .render(&gpu, &scene, &buffers, &targets, &readback)
                .with_context(|| format!("frame {frame}"))?;
            let image = readback.frame()?;
            if frame < reference {
                continue;
            }
            match &first {
                None => first = Some(image),
                Some(first) if !same(first, &image) => differing.push(frame),
                Some(_) => {}
            }
        }
        let seconds = start.elapsed().as_secs_f64();
        (first.context("no frame rendered")?, seconds, differing)
    };
    let out = &args.out;
    let clear_depth = scene.plan.main_clear_depth();
    for path in readback::write_images(out, &first, clear_depth)? {
        say(&format!("wrote: {}", path.display()));
    }
    let (truth, truth_report) = ground_truth::compute(&scene, first.width, first.height)
        .map_err(|e| anyhow::anyhow!("the stress scene has no ground truth: {e}"))?;
    for (name, bytes) in [
        (ground_truth::W_FILE, truth.w_bytes()),
        (ground_truth::ID_FILE, truth.id_bytes()),
    ] {
        let path = out.join(name);
        std::fs::write(&path, bytes).with_context(|| format!("cannot write {}", path.display()))?;
    }

    // Counted after the device and instance are gone, as for a render.
    let log = gpu.validation_log();
    drop(gpu);
    let messages = log.count();
    let stats = first
        .depth
        .as_ref()
        .map(|depth| DepthStats::of(depth, clear_depth));
    let report = RenderReport {
        device: device_info.name.clone(),
        driver: device_info.driver(),
        depth_format: args.depth_format.vk_name(),
        scene: SCENE,
        delivery: crate::plan::Delivery::Push.name(),
        width: first.width,
        height: first.height,
        views: 1,
        view: 0,
        validation_messages: messages,
        validation_skipped: None,
        features: Vec::new(),
        depth_readback: true,
        stencil_readback: false,
        clear_depth,
        depth_min: stats.and_then(|s| s.min),
        depth_max: stats.and_then(|s| s.max),
        covered_pixels: stats.map(|s| s.covered),
        multisample: None,
        ground_truth: Some(truth_report),
        recorded: Default::default(),
    };
    say(&format!(
        "wrote: {}",
        readback::write_report(out, &report)?.display()
    ));
    let stress = StressReport {
        threads: args.threads,
        frames: args.frames,
        secondaries_per_frame: args.threads,
        secondaries_without_framebuffer: args.threads / 2,
        draws_per_frame: scene.objects.len(),
        seconds,
        differing_frames: differing,
    };
    let path = out.join("stress.json");
    std::fs::write(&path, serde_json::to_string_pretty(&stress)?)
        .with_context(|| format!("cannot write {}", path.display()))?;
    say(&format!(
        "{} threads x {} frames in {seconds:.2} s",
        args.threads, args.frames
    ));
    if !stress.differing_frames.is_empty() {
        bail!(
            "{} of {} frames differ from the second (the first is a warm-up): {:?}",
            stress.differing_frames.len(),
            args.frames,
            stress.differing_frames
        );
    }
    if messages > 0 {
        eprintln!("revz-tester: {messages} validation message(s) reported");
        return Ok(ExitCode::from(2));
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_object_is_drawn_once_by_one_of_the_threads_each_pushing_its_own() {
        let scene = scene(8);
        scene
            .plan
            .check(scene.objects.len(), false)
            .expect("a valid plan");
        let Step::ExecuteSecondaries(lists, recording) = &scene.plan.steps[1] else {
            panic!("the pass records secondaries: {:?}", scene.plan.steps);
        };
        assert_eq!(
            *recording,
            Recording::ThreadPerSecondaryOddWithoutFramebuffer
        );
        assert_eq!(lists.len(), 8);
        let mut drawn: Vec<usize> = lists
            .iter()
            .flatten()
            .filter_map(|step| match step {
                Step::Draw(n) => Some(*n),
                _ => None,
            })
            .collect();
        drawn.sort_unstable();
        assert_eq!(drawn, (0..scene.objects.len()).collect::<Vec<_>>());
        assert!(lists.iter().all(|list| list[0] == Step::Bind(0)));
        let mut colors: Vec<[u8; 4]> = scene
            .objects
            .iter()
            .map(|o| o.color.map(|c| (c * 255.0).round() as u8))
            .collect();
        colors.sort_unstable();
        colors.dedup();
        assert_eq!(colors.len(), scene.objects.len(), "distinct colors");
    }
}
