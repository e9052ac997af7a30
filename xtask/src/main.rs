//! `cargo xtask`: the one driver for building, demonstrating and testing revz.
//!
//! - `setup`: install the system packages revz needs (Vulkan loader, lavapipe, validation),
//!   and a newer lavapipe beside the system's for the shader-object tests.
//! - `build`: build the layer and the tester, and render the layer manifests next to them.
//! - `demo`: what revz does, in about a minute after the (release) build: the hard cases
//!   without and with the layer against ground truth, the wrong-pixel table, a labelled
//!   side-by-side picture, and a quick cost figure (`revz-tester demo`).
//! - `report`: the whole accuracy report (every hard case, mode and depth format).
//! - `bench`: the whole benchmark (every mode against no layer, interleaved in one run).
//! - `test`: everything `build` does, then the whole test suite, then the fuzz targets for
//!   30 s each.
//! - `fuzz`: the fuzz targets alone, for as long as asked.
//! - `install` / `uninstall`: the implicit layer for the current user.
//! - `package`: a Debian package installing the implicit layer system-wide (release build).
//! - `run`: any program with revz injected, nothing installed.

mod install;
mod manifest;
mod package;
mod piglit;
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
    /// Install the system packages revz needs (apt-get; prints the command if it cannot), and
    /// on Debian 12 extract a newer lavapipe (bookworm-backports) into
    /// target/lavapipe-backports for the tests that need VK_EXT_shader_object.
    Setup,
    /// Build the layer and the tester and write the layer manifests.
    Build {
        #[arg(long)]
        release: bool,
    },
    /// What revz does, in about a minute after the release build: the hard cases on lavapipe
    /// without and with the layer against ground truth, the wrong-pixel table, a labelled
    /// side-by-side picture and a quick cost figure, into target/revz-demo.
    Demo {
        /// REVZ_MODE for the renders with the layer (flip, complementary, infinite).
        #[arg(long, default_value = "infinite")]
        mode: String,
    },
    /// The whole accuracy report (release build): every hard case in every mode and depth
    /// format against ground truth, into target/revz-report (a few minutes).
    Report,
    /// The whole benchmark (release build): every mode against no layer, interleaved in one
    /// run, into target/revz-bench (about 10 minutes on 2 cores; `--quick`: seconds, and the
    /// figures mean nothing).
    Bench {
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
    /// piglit's OpenGL depth tests through Zink on lavapipe (Debian's `piglit`, installed
    /// if missing: 2 GB), without revz and in each mode, on the system's Zink and Mesa
    /// 25.0's where `setup` extracted it: which results revz changes, into
    /// target/revz-piglit (release build; minutes).
    Piglit(piglit::PiglitArgs),
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

    /// The build's target directory (above the profile's).
    pub fn target(&self) -> PathBuf {
        self.profile_dir
            .parent()
            .map_or_else(|| self.root.join("target"), Path::to_path_buf)
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

/// A release build, then `revz-tester <args> --out target/<dir>` on it.
fn release_tester(args: &[&str], dir: &str) -> Result<PathBuf> {
    system::ensure_packages()?;
    // Release: the figures measure the layer as users run it.
    let paths = Paths::new(true);
    let explicit = build(&paths, true)?;
    let out = paths.root.join("target").join(dir);
    let mut command = Command::new(paths.tester());
    command
        .args(args)
        .arg("--layer-dir")
        .arg(&explicit)
        .arg("--out")
        .arg(&out);
    let started = std::time::Instant::now();
    run_checked(command)?;
    eprintln!(
        "xtask: {} took {:.0} s after the build",
        args.first().copied().unwrap_or("revz-tester"),
        started.elapsed().as_secs_f64()
    );
    Ok(out)
}

fn demo(mode: &str) -> Result<()> {
    let out = release_tester(&["demo", "--mode", mode], "revz-demo")?;
    println!(
        "renders and report: {} ({})",
        out.join("report.md").display(),
        out.join("images").display()
    );
    Ok(())
}

fn report() -> Result<()> {
    let out = release_tester(&["report"], "revz-report")?;
    println!("report: {}", out.join("report.md").display());
    Ok(())
}

fn bench(quick: bool) -> Result<()> {
    let args: &[&str] = if quick {
        &["bench", "--quick"]
    } else {
        &["bench"]
    };
    let out = release_tester(args, "revz-bench")?;
    println!("bench: {}", out.join("bench.json").display());
    Ok(())
}

/// The system packages, the newer lavapipe the shader-object tests render on
/// ([`system::ensure_newer_lavapipe`]), and the newer Zink beside it
/// ([`system::ensure_newer_zink`]).
fn setup() -> Result<()> {
    system::ensure_packages()?;
    let target = Paths::new(false).target();
    system::ensure_newer_lavapipe(&target);
    system::ensure_newer_zink(&target);
    Ok(())
}

fn test(extra: &[String]) -> Result<()> {
    setup()?;
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
        Task::Setup => setup(),
        Task::Build { release } => build(&Paths::new(release), release).map(drop),
        Task::Demo { mode } => demo(&mode),
        Task::Report => report(),
        Task::Bench { quick } => bench(quick),
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
        Task::Piglit(args) => piglit::piglit(&args),
    }
}
