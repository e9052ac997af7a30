//! `cargo xtask`: the one driver for building, demonstrating and testing revz.
//!
//! - `setup`: install the system packages revz needs (Vulkan loader, lavapipe, validation).
//! - `build`: build the layer and the tester, and render the layer manifests next to them.
//! - `demo`: render the first scene without and with the layer, then the accuracy report and
//!   the benchmark (release build): print where the images and the report are, and the table.
//! - `test`: everything `build` does, then the whole test suite, then the fuzz targets for
//!   30 s each.
//! - `fuzz`: the fuzz targets alone, for as long as asked.
//! - `install` / `uninstall`: the implicit layer for the current user.
//! - `package`: a Debian package installing the implicit layer system-wide (release build).
//! - `run`: any program with revz injected, nothing installed.

mod install;
mod manifest;
mod package;
mod system;

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(about = "Build, demo and test driver for revz")]
struct Cli {
    #[command(subcommand)]
    task: Task,
}

#[derive(Subcommand, Debug)]
enum Task {
    /// Install the system packages revz needs (apt-get; prints the command if it cannot).
    Setup,
    /// Build the layer and the tester and write the layer manifests.
    Build {
        #[arg(long)]
        release: bool,
    },
    /// Render the first scene on lavapipe without and with the layer, then write the accuracy
    /// report and run the benchmark (release build) into target/revz-demo/report.
    Demo {
        /// REVZ_MODE for the render with the layer.
        #[arg(long, default_value = "complementary")]
        mode: String,
        /// Depth format (d16, x8-d24, d24-s8, d32, d32-s8).
        #[arg(long, default_value = "d32")]
        depth_format: String,
        /// Run the benchmark with tiny counts (seconds instead of minutes; the figures then
        /// mean nothing).
        #[arg(long)]
        quick: bool,
    },
    /// Build, then run the whole test suite (extra arguments go to `cargo test`).
    Test {
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        cargo_test_args: Vec<String>,
    },
    /// Run the fuzz targets (layer/src/fuzz), one after another, each for `seconds`.
    Fuzz {
        /// How long each target runs.
        #[arg(long, default_value_t = 30)]
        seconds: u64,
        /// A release build (more cases per second; CI fuzzes the test build it already has).
        #[arg(long)]
        release: bool,
        /// Only the targets whose name contains this (vertex_analysis, fragment_rewrite,
        /// chain_splice, config).
        target: Option<String>,
    },
    /// Install revz as an implicit layer for the current user (active with ENABLE_REVZ=1).
    Install(install::BuildChoice),
    /// Remove what `install` installed.
    Uninstall,
    /// Run a program with revz injected, without installing anything:
    /// `cargo xtask run --mode infinite -- vkcube`.
    Run(install::RunArgs),
    /// Build the Debian package (release build) into target/debian: the layer in
    /// /usr/lib/<multiarch>/ and its implicit manifest in /usr/share/vulkan/implicit_layer.d/,
    /// active with ENABLE_REVZ=1.
    Package(package::PackageArgs),
}

/// Where things are in the workspace and its build output.
#[derive(Debug)]
pub struct Paths {
    root: PathBuf,
    profile_dir: PathBuf,
}

impl Paths {
    pub fn new(release: bool) -> Paths {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .expect("xtask lives in the workspace")
            .to_path_buf();
        let target = std::env::var_os("CARGO_TARGET_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|| root.join("target"));
        let profile_dir = target.join(if release { "release" } else { "debug" });
        Paths { root, profile_dir }
    }

    pub fn library(&self) -> PathBuf {
        self.profile_dir.join("libVkLayer_revz.so")
    }

    fn tester(&self) -> PathBuf {
        self.profile_dir.join("revz-tester")
    }

    pub fn manifests(&self) -> PathBuf {
        self.profile_dir.join("manifests")
    }
}

fn cargo() -> Command {
    Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
}

fn run_checked(mut command: Command) -> Result<()> {
    let status = command
        .status()
        .with_context(|| format!("starting {command:?}"))?;
    if !status.success() {
        bail!("{command:?} failed ({status})");
    }
    Ok(())
}

/// Builds the layer and tester and writes the manifests; returns the explicit manifest's dir.
pub fn build(paths: &Paths, release: bool) -> Result<PathBuf> {
    let mut command = cargo();
    command.current_dir(&paths.root).args([
        "build",
        "-p",
        "revz-layer",
        "-p",
        "revz-tester",
        "-p",
        "revz-count-layer",
    ]);
    if release {
        command.arg("--release");
    }
    run_checked(command)?;
    let explicit = manifest::write_all(&paths.root, &paths.library(), &paths.manifests())?;
    // The benchmark's counting layer, in a directory of its own (the loader stacks layers in
    // the order it finds their manifests).
    manifest::write_count_layer(
        &paths.root,
        &paths.profile_dir.join("libVkLayer_revz_count.so"),
        &paths.manifests().join("count"),
    )?;
    eprintln!("xtask: layer {}", paths.library().display());
    eprintln!("xtask: manifests in {}", paths.manifests().display());
    Ok(explicit)
}

fn demo(mode: &str, depth_format: &str, quick: bool) -> Result<()> {
    system::ensure_packages()?;
    // Release: the benchmark measures the layer as users run it.
    let paths = Paths::new(true);
    let explicit = build(&paths, true)?;
    let out = paths.root.join("target").join("revz-demo");
    let native = out.join("native");
    let layered = out.join(format!("revz-{mode}"));

    let tester = |dir: &Path| {
        let mut command = Command::new(paths.tester());
        command.args(["--validation", "--depth-format", depth_format, "--out"]);
        command.arg(dir);
        command
    };
    println!("== without the layer");
    run_checked(tester(&native))?;
    println!("== with revz (REVZ_MODE={mode})");
    let mut with_layer = tester(&layered);
    with_layer
        .env("VK_ADD_LAYER_PATH", &explicit)
        .env("VK_INSTANCE_LAYERS", "VK_LAYER_REVZ_reverse_z")
        .env("REVZ_MODE", mode)
        .env("REVZ_LOG", "info");
    run_checked(with_layer)?;

    println!("== results");
    for (name, dir) in [("without the layer", &native), ("with revz", &layered)] {
        println!(
            "{name:>18}: {}  {}",
            dir.join("color.png").display(),
            dir.join("depth.png").display()
        );
    }
    for file in ["color.png", "depth.f32"] {
        let a = std::fs::read(native.join(file))?;
        let b = std::fs::read(layered.join(file))?;
        let verdict = if a == b { "identical" } else { "different" };
        println!("{file:>18}: {verdict}");
    }

    let report = out.join("report");
    println!("== accuracy report (every hard case, mode and depth format against ground truth)");
    let mut accuracy = Command::new(paths.tester());
    accuracy.arg("report").arg("--out").arg(&report);
    run_checked(accuracy)?;
    println!("== benchmark (every mode against no layer, interleaved in one run)");
    let mut bench = Command::new(paths.tester());
    bench.arg("bench").arg("--out").arg(&report);
    if quick {
        bench.arg("--quick");
    }
    run_checked(bench)?;
    println!(
        "report: {} ({})",
        report.join("report.md").display(),
        report.join("report.json").display()
    );
    Ok(())
}

fn test(extra: &[String]) -> Result<()> {
    system::ensure_packages()?;
    let paths = Paths::new(false);
    build(&paths, false)?;
    let mut command = cargo();
    command
        .current_dir(&paths.root)
        .args(["test", "--workspace"])
        .args(extra);
    run_checked(command)?;
    if extra.is_empty() {
        // The fuzz targets ran for a second each above; now for their CI time, on the same
        // build (no rebuild: same packages, profile and features).
        let seconds = std::env::var("REVZ_FUZZ_SECONDS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(30);
        fuzz(&paths, seconds, false, None)?;
    }
    Ok(())
}

/// Runs the layer's fuzz targets one after another (each target is a test `fuzz::...`),
/// printing each one's case count.
fn fuzz(paths: &Paths, seconds: u64, release: bool, target: Option<&str>) -> Result<()> {
    println!("== fuzzing, {seconds} s per target");
    let filter = match target {
        Some(name) => format!("fuzz::{name}"),
        None => "fuzz::".to_owned(),
    };
    let mut command = cargo();
    command
        .current_dir(&paths.root)
        .env("REVZ_FUZZ_SECONDS", seconds.to_string())
        // Only the layer has fuzz targets: its run is the last the output shows (no crate's
        // "0 passed" after it), and it reuses the suite's build.
        .args(["test", "-p", "revz-layer", "--lib"]);
    if release {
        command.arg("--release");
    }
    // The engine's own tests (which fail runs on purpose) ran with the suite.
    command.args([
        "--",
        &filter,
        "--skip",
        "fuzz::engine_tests",
        "--skip",
        "fuzz::spirv::",
        "--test-threads=1",
        "--nocapture",
    ]);
    run_checked(command)
}

fn main() -> Result<()> {
    match Cli::parse().task {
        Task::Setup => system::ensure_packages(),
        Task::Build { release } => build(&Paths::new(release), release).map(drop),
        Task::Demo {
            mode,
            depth_format,
            quick,
        } => demo(&mode, &depth_format, quick),
        Task::Test { cargo_test_args } => test(&cargo_test_args),
        Task::Fuzz {
            seconds,
            release,
            target,
        } => fuzz(&Paths::new(release), seconds, release, target.as_deref()),
        Task::Install(choice) => install::install(&choice),
        Task::Uninstall => install::uninstall(),
        Task::Run(args) => install::run(&args),
        Task::Package(args) => package::package(&args),
    }
}
