//! Installing revz for the current user, and running a program with revz injected.
//!
//! `install` copies the layer to `$XDG_DATA_HOME/revz/` (default `~/.local/share/revz/`) and
//! writes the implicit manifest to `$XDG_DATA_HOME/vulkan/implicit_layer.d/`, where the loader
//! looks for a user's implicit layers; the layer is then active in any program started with
//! `ENABLE_REVZ=1`, and `DISABLE_REVZ=1` turns it off. `run` needs no installation: it points
//! the loader at the build tree's explicit manifest for one program.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use clap::Args;

use crate::manifest::{self, Kind};
use crate::{build, Paths};

/// Which build of the layer to use.
#[derive(Args, Debug, Clone)]
pub struct BuildChoice {
    /// Use the debug build instead of the release build.
    #[arg(long)]
    debug: bool,
    /// Do not build: use what the last build left in target/.
    #[arg(long)]
    no_build: bool,
}

impl BuildChoice {
    /// The build output to use (building it unless told not to); returns the paths.
    fn prepare(&self) -> Result<Paths> {
        let release = !self.debug;
        let paths = Paths::new(release);
        if !self.no_build {
            build(&paths, release)?;
        }
        if !paths.library().exists() {
            bail!(
                "{} does not exist: build it with `cargo xtask build{}`",
                paths.library().display(),
                if release { " --release" } else { "" }
            );
        }
        Ok(paths)
    }
}

/// Arguments of `run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    build: BuildChoice,
    /// REVZ_MODE for the program: off, flip, complementary, infinite.
    #[arg(long)]
    mode: Option<String>,
    /// REVZ_FAR_CLIP for the program: remove, keep.
    #[arg(long)]
    far_clip: Option<String>,
    /// REVZ_LOG for the program: off, error, warn, info, debug, trace.
    #[arg(long)]
    log: Option<String>,
    /// Write revz's depth profile into this directory (REVZ_REPORT) and print its summary when
    /// the program ends (default directory: target/revz-report).
    #[arg(long, value_name = "DIR", num_args = 0..=1, default_missing_value = "target/revz-report")]
    report: Option<PathBuf>,
    /// The program and its arguments.
    #[arg(required = true, trailing_var_arg = true, allow_hyphen_values = true)]
    command: Vec<String>,
}

/// Where a user's data goes: `$XDG_DATA_HOME`, else `~/.local/share`.
fn data_home() -> Result<PathBuf> {
    if let Some(dir) = std::env::var_os("XDG_DATA_HOME").filter(|d| !d.is_empty()) {
        return Ok(PathBuf::from(dir));
    }
    let home = std::env::var_os("HOME").context("neither XDG_DATA_HOME nor HOME is set")?;
    Ok(Path::new(&home).join(".local/share"))
}

/// The installed library and manifest.
struct Installed {
    library: PathBuf,
    manifest: PathBuf,
}

impl Installed {
    fn locate() -> Result<Installed> {
        let data = data_home()?;
        Ok(Installed {
            library: data.join("revz").join("libVkLayer_revz.so"),
            manifest: data
                .join("vulkan/implicit_layer.d")
                .join(manifest::FILE_NAME),
        })
    }
}

pub fn install(choice: &BuildChoice) -> Result<()> {
    let paths = choice.prepare()?;
    let installed = Installed::locate()?;
    let lib_dir = installed.library.parent().expect("a file in a directory");
    std::fs::create_dir_all(lib_dir).with_context(|| format!("creating {}", lib_dir.display()))?;
    // Copy to a temporary name and rename, so a running program never maps a half-written file.
    let partial = installed.library.with_extension("so.partial");
    std::fs::copy(paths.library(), &partial)
        .with_context(|| format!("copying the layer to {}", partial.display()))?;
    std::fs::rename(&partial, &installed.library)?;
    let manifest_dir = installed.manifest.parent().expect("a file in a directory");
    manifest::write(
        &paths.root,
        &installed.library,
        Kind::Implicit,
        manifest_dir,
    )?;
    println!("installed {}", installed.library.display());
    println!("installed {}", installed.manifest.display());
    println!(
        "revz is now an implicit layer, active in programs started with {}=1 \
         (for example `{}=1 vulkaninfo --summary`); {}=1 turns it off",
        manifest::ENABLE_VAR,
        manifest::ENABLE_VAR,
        manifest::DISABLE_VAR
    );
    Ok(())
}

pub fn uninstall() -> Result<()> {
    let installed = Installed::locate()?;
    let mut removed = 0;
    for path in [&installed.manifest, &installed.library] {
        match std::fs::remove_file(path) {
            Ok(()) => {
                println!("removed {}", path.display());
                removed += 1;
            }
            Err(err) if err.kind() == std::io::ErrorKind::NotFound => {}
            Err(err) => return Err(err).with_context(|| format!("removing {}", path.display())),
        }
    }
    // Only our own directory, and only if empty.
    let _ = std::fs::remove_dir(installed.library.parent().expect("a file in a directory"));
    if removed == 0 {
        println!(
            "revz was not installed (nothing at {})",
            installed.manifest.display()
        );
    }
    Ok(())
}

/// Prepends `value` to a `:`-separated list variable.
fn prepend(name: &str, value: &str) -> String {
    match std::env::var(name) {
        Ok(existing) if !existing.is_empty() => format!("{value}:{existing}"),
        _ => value.to_owned(),
    }
}

pub fn run(args: &RunArgs) -> Result<()> {
    let paths = args.build.prepare()?;
    let explicit = Kind::Explicit.dir(&paths.manifests());
    let mut command = Command::new(&args.command[0]);
    command
        .args(&args.command[1..])
        .env(
            "VK_ADD_LAYER_PATH",
            prepend("VK_ADD_LAYER_PATH", &explicit.to_string_lossy()),
        )
        .env(
            "VK_INSTANCE_LAYERS",
            prepend("VK_INSTANCE_LAYERS", "VK_LAYER_REVZ_reverse_z"),
        );
    for (name, value) in [
        ("REVZ_MODE", &args.mode),
        ("REVZ_FAR_CLIP", &args.far_clip),
        ("REVZ_LOG", &args.log),
    ] {
        if let Some(value) = value {
            command.env(name, value);
        }
    }
    let started = std::time::SystemTime::now();
    if let Some(dir) = &args.report {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the report directory {}", dir.display()))?;
        command.env("REVZ_REPORT", dir);
    }
    let status = command
        .status()
        .with_context(|| format!("starting {}", args.command[0]))?;
    if let Some(dir) = &args.report {
        print_profiles(dir, started);
    }
    std::process::exit(status.code().unwrap_or(1));
}

/// The summary of every depth profile written into `dir` since `since`.
fn print_profiles(dir: &Path, since: std::time::SystemTime) {
    let entries = std::fs::read_dir(dir).into_iter().flatten().flatten();
    let mut found = false;
    for entry in entries {
        let path = entry.path();
        let fresh = entry
            .metadata()
            .and_then(|m| m.modified())
            .is_ok_and(|modified| modified >= since);
        if !fresh || path.extension().is_none_or(|e| e != "json") {
            continue;
        }
        let summary = std::fs::read_to_string(&path)
            .ok()
            .and_then(|text| serde_json::from_str::<serde_json::Value>(&text).ok())
            .and_then(|profile| profile["summary"].as_str().map(str::to_owned));
        if let Some(summary) = summary {
            found = true;
            println!(
                "revz: {summary}\n  ({}; `revz-tester profile` shows it whole)",
                path.display()
            );
        }
    }
    if !found {
        println!(
            "revz: no depth profile in {} (did the program create a Vulkan device through revz?)",
            dir.display()
        );
    }
}
