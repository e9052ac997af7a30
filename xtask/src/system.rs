//! The system packages revz needs to build, render and test, and their installation.
//!
//! On Debian and Ubuntu the missing packages are installed with `apt-get` when we are root or
//! have password-less sudo; otherwise the exact command to run is printed and the task fails.

use std::process::Command;

use anyhow::{bail, Result};

/// Debian package names, with what each provides.
pub const PACKAGES: &[(&str, &str)] = &[
    ("libvulkan1", "the Vulkan loader"),
    (
        "mesa-vulkan-drivers",
        "lavapipe, the CPU Vulkan driver the tests render on",
    ),
    (
        "vulkan-validationlayers",
        "the Khronos validation layer every test render runs under",
    ),
    ("vulkan-tools", "vulkaninfo"),
    ("spirv-tools", "spirv-val, which checks the tester's SPIR-V"),
    (
        "glslang-tools",
        "glslangValidator, which checks the committed shaders/glslang/*.spv",
    ),
    (
        "libegl1",
        "libEGL.so.1 (glvnd), which `revz-tester gl-render` loads",
    ),
    (
        "libegl-mesa0",
        "Mesa's EGL and its surfaceless platform, for headless OpenGL",
    ),
    (
        "libgl1-mesa-dri",
        "Mesa's OpenGL drivers: llvmpipe and Zink (zink_dri.so), OpenGL on Vulkan",
    ),
    (
        "fonts-dejavu-core",
        "DejaVu Sans, the font of the report's plots",
    ),
];

fn is_installed(package: &str) -> bool {
    Command::new("dpkg-query")
        .args(["-W", "-f=${Status}", package])
        .output()
        .is_ok_and(|out| String::from_utf8_lossy(&out.stdout).contains("install ok installed"))
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|out| String::from_utf8_lossy(&out.stdout).trim() == "0")
}

fn has_passwordless_sudo() -> bool {
    Command::new("sudo")
        .args(["-n", "true"])
        .status()
        .is_ok_and(|s| s.success())
}

fn run(program: &str, args: &[&str]) -> Result<()> {
    eprintln!("xtask: running {program} {}", args.join(" "));
    let status = Command::new(program)
        .args(args)
        .env("DEBIAN_FRONTEND", "noninteractive")
        .status()?;
    if !status.success() {
        bail!("{program} {} failed ({status})", args.join(" "));
    }
    Ok(())
}

/// Makes sure every package in [`PACKAGES`] is installed.
pub fn ensure_packages() -> Result<()> {
    if Command::new("dpkg-query")
        .arg("--version")
        .output()
        .is_err()
    {
        eprintln!(
            "xtask: not a Debian-based system; make sure these are installed: {}",
            PACKAGES
                .iter()
                .map(|(_, what)| *what)
                .collect::<Vec<_>>()
                .join("; ")
        );
        return Ok(());
    }
    install_missing(&PACKAGES.iter().map(|(name, _)| *name).collect::<Vec<_>>())
}

/// Installs those of `packages` that are missing (Debian: `apt-get`, as root or through
/// password-less sudo; otherwise the command to run, and an error).
pub fn install_missing(packages: &[&str]) -> Result<()> {
    let missing: Vec<&str> = packages
        .iter()
        .copied()
        .filter(|name| !is_installed(name))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    let mut install = vec!["install", "-y", "--no-install-recommends"];
    install.extend(&missing);
    if is_root() {
        run("apt-get", &["update"])?;
        run("apt-get", &install)?;
    } else if has_passwordless_sudo() {
        let mut update = vec!["apt-get", "update"];
        run("sudo", &update)?;
        update.truncate(1);
        update.extend(&install);
        run("sudo", &update)?;
    } else {
        bail!(
            "missing system packages: {}\nrun: sudo apt-get update && sudo apt-get install -y {}",
            missing.join(", "),
            missing.join(" ")
        );
    }
    Ok(())
}

/// Where [`ensure_newer_lavapipe`] keeps its driver, under the build's target directory.
pub const NEWER_LAVAPIPE_DIR: &str = "lavapipe-backports";
/// The driver manifest (ICD JSON) of the newer lavapipe, in [`NEWER_LAVAPIPE_DIR`].
pub const NEWER_LAVAPIPE_ICD: &str = "lvp_icd.json";
/// The Debian suite the newer lavapipe comes from, and the suite of the system it runs on.
const BACKPORTS_SUITE: &str = "bookworm-backports";

/// A newer lavapipe than the system's, beside it and not installed: Debian 12's
/// `mesa-vulkan-drivers` from `bookworm-backports` (Mesa 25.0, built against the same
/// LLVM 15), downloaded with a private apt state and extracted under
/// `<target>/lavapipe-backports/root`, with a driver manifest naming its library by its full
/// path. The tests that need what Mesa 22.3's lavapipe lacks (`VK_EXT_shader_object`) select it
/// with `VK_DRIVER_FILES`; everything else keeps rendering on the system's driver.
///
/// Done once (kept while the manifest and library exist). Returns the manifest, or `None`
/// with a message where this is not Debian 12 (a newer system's own lavapipe has these
/// extensions already) or the download fails.
pub fn ensure_newer_lavapipe(target: &std::path::Path) -> Option<std::path::PathBuf> {
    let dir = target.join(NEWER_LAVAPIPE_DIR);
    let icd = dir.join(NEWER_LAVAPIPE_ICD);
    let library = dir.join("root/usr/lib/x86_64-linux-gnu/libvulkan_lvp.so");
    if icd.exists() && library.exists() {
        return Some(icd);
    }
    let os_release = std::fs::read_to_string("/etc/os-release").unwrap_or_default();
    if !os_release.lines().any(|l| l == "VERSION_CODENAME=bookworm") || !is_root() {
        eprintln!(
            "xtask: not fetching a newer lavapipe (Debian 12 as root only): the shader-object \
             tests render on the system's lavapipe, which needs VK_EXT_shader_object"
        );
        return None;
    }
    match fetch_newer_lavapipe(&dir, &library, &icd) {
        Ok(()) => Some(icd),
        Err(e) => {
            eprintln!("xtask: could not fetch the newer lavapipe: {e:#}");
            None
        }
    }
}

/// Mesa 25.0's OpenGL drivers from `bookworm-backports` beside [`ensure_newer_lavapipe`]'s
/// Vulkan driver, in the same root: `mesa-libgallium`, `libgl1-mesa-dri`, `libegl-mesa0` and
/// `libgbm1`, and an EGL vendor manifest naming that libEGL by its full path
/// ([`NEWER_ZINK_EGL`]). The Zink tests render through this newer Zink too (on the newer
/// lavapipe), whose Vulkan use differs from 22.3's, with `LD_LIBRARY_PATH`,
/// `LIBGL_DRIVERS_PATH` and `__EGL_VENDOR_LIBRARY_FILENAMES` (`tests/src/lib.rs`).
///
/// Done once (kept while the manifest and Zink's driver exist), only where the newer lavapipe
/// is; a failure is reported and leaves the Zink tests on the system's Zink alone.
pub fn ensure_newer_zink(target: &std::path::Path) {
    let dir = target.join(NEWER_LAVAPIPE_DIR);
    let libs = dir.join("root/usr/lib/x86_64-linux-gnu");
    let (egl, zink) = (dir.join(NEWER_ZINK_EGL), libs.join("dri/zink_dri.so"));
    if egl.exists() && zink.exists() {
        return;
    }
    if !dir.join(NEWER_LAVAPIPE_ICD).exists() {
        return;
    }
    let packages = [
        "mesa-libgallium",
        "libgl1-mesa-dri",
        "libegl-mesa0",
        "libgbm1",
    ];
    let fetched = backports_extract(&dir, &packages).and_then(|()| {
        let library = libs.join("libEGL_mesa.so.0");
        if !zink.exists() || !library.exists() {
            bail!(
                "the packages hold no {} or {}",
                zink.display(),
                library.display()
            );
        }
        let manifest = format!(
            "{{\n    \"file_format_version\": \"1.0.0\",\n    \"ICD\": {{\n        \
             \"library_path\": \"{}\"\n    }}\n}}\n",
            library.display()
        );
        std::fs::write(&egl, manifest)?;
        Ok(())
    });
    match fetched {
        Ok(()) => eprintln!("xtask: newer Zink (Mesa 25.0) in {}", libs.display()),
        Err(e) => eprintln!("xtask: could not fetch the newer Zink: {e:#}"),
    }
}

/// The EGL vendor manifest of the newer Zink's libEGL, in [`NEWER_LAVAPIPE_DIR`].
pub const NEWER_ZINK_EGL: &str = "zink_egl_vendor.json";

/// Downloads `packages` from `bookworm-backports` with [`fetch_newer_lavapipe`]'s private apt
/// state (its lists updated already) and extracts them into `<dir>/root`.
fn backports_extract(dir: &std::path::Path, packages: &[&str]) -> Result<()> {
    let apt = dir.join("apt");
    let download_dir = apt.join("zink-download");
    std::fs::create_dir_all(&download_dir)?;
    let mut download = Command::new("apt-get");
    for option in apt_options(&apt) {
        download.arg("-o").arg(option);
    }
    download
        .current_dir(&download_dir)
        .arg("download")
        .args(packages.iter().map(|p| format!("{p}/{BACKPORTS_SUITE}")));
    run_command(download, "apt-get download (newer Zink)")?;
    for entry in std::fs::read_dir(&download_dir)? {
        let deb = entry?.path();
        if deb.extension().is_some_and(|e| e == "deb") {
            let mut extract = Command::new("dpkg-deb");
            extract.arg("-x").arg(&deb).arg(dir.join("root"));
            run_command(extract, "dpkg-deb -x")?;
        }
    }
    Ok(())
}

/// apt's options for the private state under `apt` (sources, lists, cache): the system's apt
/// configuration is left as it is.
fn apt_options(apt: &std::path::Path) -> [String; 5] {
    [
        format!(
            "Dir::Etc::SourceList={}",
            apt.join("backports.sources").display()
        ),
        "Dir::Etc::SourceParts=-".to_owned(),
        format!("Dir::State::Lists={}", apt.join("lists").display()),
        format!("Dir::Cache={}", apt.join("cache").display()),
        "APT::Sandbox::User=root".to_owned(),
    ]
}

fn fetch_newer_lavapipe(
    dir: &std::path::Path,
    library: &std::path::Path,
    icd: &std::path::Path,
) -> Result<()> {
    use anyhow::Context;
    let apt = dir.join("apt");
    for sub in ["lists/partial", "cache/archives/partial", "download"] {
        std::fs::create_dir_all(apt.join(sub))?;
    }
    let sources = apt.join("backports.sources");
    std::fs::write(
        &sources,
        format!(
            "Types: deb\nURIs: http://deb.debian.org/debian\nSuites: {BACKPORTS_SUITE}\n\
             Components: main\n"
        ),
    )?;
    // Private sources, lists and cache: the system's apt configuration is left as it is.
    let options = apt_options(&apt);
    let with_options = |command: &mut Command| {
        for option in &options {
            command.arg("-o").arg(option);
        }
    };
    let mut update = Command::new("apt-get");
    with_options(&mut update);
    update.arg("update");
    run_command(update, "apt-get update (bookworm-backports)")?;
    let download_dir = apt.join("download");
    let mut download = Command::new("apt-get");
    with_options(&mut download);
    download.current_dir(&download_dir).args([
        "download",
        &format!("mesa-vulkan-drivers/{BACKPORTS_SUITE}"),
    ]);
    run_command(download, "apt-get download mesa-vulkan-drivers")?;
    let deb = std::fs::read_dir(&download_dir)?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .find(|path| path.extension().is_some_and(|e| e == "deb"))
        .context("apt-get download left no .deb")?;
    let root = dir.join("root");
    let mut extract = Command::new("dpkg-deb");
    extract.arg("-x").arg(&deb).arg(&root);
    run_command(extract, "dpkg-deb -x")?;
    if !library.exists() {
        bail!("{} holds no {}", deb.display(), library.display());
    }
    let manifest = format!(
        "{{\n    \"file_format_version\": \"1.0.0\",\n    \"ICD\": {{\n        \
         \"library_path\": \"{}\",\n        \"api_version\": \"1.3.0\"\n    }}\n}}\n",
        library.display()
    );
    std::fs::write(icd, manifest)?;
    eprintln!(
        "xtask: newer lavapipe from {} in {}",
        deb.file_name().unwrap_or_default().to_string_lossy(),
        root.display()
    );
    Ok(())
}

fn run_command(mut command: Command, what: &str) -> Result<()> {
    eprintln!("xtask: {what}");
    let status = command.env("DEBIAN_FRONTEND", "noninteractive").status()?;
    if !status.success() {
        bail!("{what} failed ({status})");
    }
    Ok(())
}
