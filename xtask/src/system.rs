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
    let missing: Vec<&str> = PACKAGES
        .iter()
        .map(|(name, _)| *name)
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
