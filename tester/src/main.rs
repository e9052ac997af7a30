//! `revz-tester`: an ordinary headless Vulkan application that renders a known scene offscreen
//! (standard depth: clear 1.0, compare LESS) and writes what it rendered to files. It knows
//! nothing of the revz layer; the layer, when injected, changes what it renders.
//!
//! This file owns the command line and the orchestration only; see the modules for the rest.
//!
//! Exit codes: 0 = rendered, no counted validation message; 1 = error; 2 = rendered (files
//! written) but the validation layer reported messages.

mod gpu;
mod readback;
mod render;
mod scene;
mod shaders;
mod target;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Parser;

use crate::gpu::{Gpu, GpuOptions};
use crate::readback::{DepthStats, Readback, RenderReport};
use crate::render::{Renderer, SceneBuffers, CLEAR_DEPTH};
use crate::scene::SceneId;
use crate::target::{DepthFormat, Targets};

/// Renders a known scene offscreen with Vulkan and writes color.png, depth.png, depth.f32 and
/// render.json.
#[derive(Debug, Parser)]
#[command(name = "revz-tester", version)]
struct Cli {
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

    /// Width of the render in pixels.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: u32,

    /// Height of the render in pixels.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: u32,

    /// Enable VK_LAYER_KHRONOS_validation and count its messages (exit code 2 if any).
    #[arg(long)]
    validation: bool,

    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
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
    match run(&cli) {
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

/// Renders and writes the outputs; returns the number of counted validation messages.
fn run(cli: &Cli) -> Result<u32> {
    std::fs::create_dir_all(&cli.out)
        .with_context(|| format!("cannot create output directory {}", cli.out.display()))?;
    let scene = cli.scene.build();

    let gpu = Gpu::new(&GpuOptions {
        device: cli.device.clone(),
        validation: cli.validation,
    })?;
    say(&format!(
        "device: {} ({}, Vulkan {})",
        gpu.info.name,
        gpu.info.driver(),
        gpu.info.api_version_string()
    ));
    let device_info = gpu.info.clone();

    // Every Vulkan object lives inside this block and is destroyed when it ends (in reverse
    // order of creation); only host data leaves it.
    let frame = {
        let targets = Targets::new(&gpu, cli.width, cli.height, cli.depth_format)?;
        let buffers = SceneBuffers::upload(&gpu, &scene)?;
        let readback = Readback::new(&gpu, &targets)?;
        let renderer = Renderer::new(&gpu, &targets)?;
        renderer.render(&gpu, &scene, &buffers, &targets, &readback)?;
        readback.frame()?
    };
    for path in readback::write_images(&cli.out, &frame)? {
        print_wrote(&path);
    }

    // Destroy the device and the instance before counting, so that what validation reports
    // at vkDestroyDevice / vkDestroyInstance (leaks) is counted too.
    let log = gpu.validation_log();
    drop(gpu);
    let messages = log.count();

    let stats = DepthStats::of(&frame.depth, CLEAR_DEPTH);
    let report = RenderReport {
        device: device_info.name.clone(),
        driver: device_info.driver(),
        depth_format: cli.depth_format.vk_name(),
        scene: cli.scene.name(),
        width: frame.width,
        height: frame.height,
        validation_messages: messages,
        depth_min: stats.min,
        depth_max: stats.max,
        covered_pixels: stats.covered,
    };
    print_wrote(&readback::write_report(&cli.out, &report)?);
    Ok(messages)
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
