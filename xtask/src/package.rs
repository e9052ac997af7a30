//! The Debian package: `cargo xtask package` and the `.deb` it builds.
//!
//! This module owns the package's layout, its `DEBIAN/control`, `md5sums` and copyright file,
//! and the call to Debian's own `dpkg-deb --root-owner-group --build` on a staging tree (no
//! hand-made archive). The package installs the release library at
//! `/usr/lib/<multiarch>/libVkLayer_revz.so` and the implicit manifest, rendered by
//! [`crate::manifest`] with that absolute path, at
//! `/usr/share/vulkan/implicit_layer.d/VkLayer_revz.json`, where the Vulkan loader looks for
//! system-wide implicit layers: like the user install, the layer is then active in programs
//! started with `ENABLE_REVZ=1`, and `DISABLE_REVZ=1` turns it off.
//!
//! [`build_deb`] needs no cargo build (the tests feed it any file as the library); [`package`]
//! is the command: a release build, then [`build_deb`] into `target/debian/`.

use std::fmt::Write as _;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use anyhow::{bail, Context, Result};
use clap::Args;

use crate::manifest::{self, Kind};
use crate::{build, Paths};

/// The binary package's name.
pub const PACKAGE: &str = "revz-vulkan-layer";
/// The library's file name, as the build makes it and as the package installs it.
pub const LIBRARY_NAME: &str = "libVkLayer_revz.so";
/// Where the loader looks for system-wide implicit layers, relative to `/`.
pub const IMPLICIT_LAYER_DIR: &str = "usr/share/vulkan/implicit_layer.d";
/// The maintainer when neither `DEBEMAIL` nor `DEBFULLNAME` says otherwise.
const DEFAULT_MAINTAINER: &str =
    "revz maintainers <maintainers@users.noreply.h-seed-d44c1d13.example>";

/// Arguments of `package`.
#[derive(Args, Debug)]
pub struct PackageArgs {
    /// Where to write the .deb (default: target/debian).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// `cargo xtask package`: release build, then the .deb, then how to install it.
pub fn package(args: &PackageArgs) -> Result<()> {
    let paths = Paths::new(true);
    build(&paths, true)?;
    let out = match &args.out {
        Some(dir) => dir.clone(),
        // The target directory (CARGO_TARGET_DIR if set), next to `release/`.
        None => paths
            .profile_dir
            .parent()
            .expect("the profile directory is in the target directory")
            .join("debian"),
    };
    let deb = build_deb(
        &paths.root,
        &paths.library(),
        env!("CARGO_PKG_VERSION"),
        &out,
    )?;
    let target = Target::host()?;
    println!("xtask: package {}", deb.display());
    println!("install it with:");
    println!("  sudo apt install {}", apt_argument(&deb));
    println!(
        "it installs {} and the implicit layer manifest /{IMPLICIT_LAYER_DIR}/{}:",
        target.installed_library().display(),
        manifest::FILE_NAME
    );
    println!(
        "revz is then active in programs started with {}=1 (for example `{}=1 vulkaninfo \
         --summary`); {}=1 turns it off; `sudo apt remove {PACKAGE}` removes it",
        manifest::ENABLE_VAR,
        manifest::ENABLE_VAR,
        manifest::DISABLE_VAR
    );
    Ok(())
}

/// `apt install` takes a local file only as a path with a slash in it.
fn apt_argument(deb: &Path) -> String {
    let text = deb.to_string_lossy();
    if text.contains('/') {
        text.into_owned()
    } else {
        format!("./{text}")
    }
}

/// The Debian architecture the package is for and its multiarch library directory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Target {
    /// `dpkg --print-architecture`: `amd64`, `arm64`, ...
    pub arch: String,
    /// The multiarch tuple: `x86_64-linux-gnu`, `aarch64-linux-gnu`, ...
    pub multiarch: String,
}

impl Target {
    /// This machine's: the architecture from dpkg, the tuple from `dpkg-architecture` (in
    /// dpkg-dev), else `gcc -print-multiarch`, else the usual tuple of the architecture.
    pub fn host() -> Result<Target> {
        let arch = tool_output("dpkg", &["--print-architecture"])?;
        let multiarch = tool_output("dpkg-architecture", &["-qDEB_HOST_MULTIARCH"])
            .ok()
            .or_else(|| tool_output("gcc", &["-print-multiarch"]).ok())
            .filter(|tuple| !tuple.is_empty())
            .or_else(|| multiarch_of(&arch).map(str::to_owned))
            .with_context(|| {
                format!(
                    "cannot tell the multiarch directory of architecture {arch}: install \
                     dpkg-dev (dpkg-architecture)"
                )
            })?;
        Ok(Target { arch, multiarch })
    }

    /// The library's absolute path once installed.
    pub fn installed_library(&self) -> PathBuf {
        Path::new("/usr/lib")
            .join(&self.multiarch)
            .join(LIBRARY_NAME)
    }

    /// `<package>_<version>_<arch>.deb`, the name Debian tools give a package file.
    pub fn file_name(&self, debian_version: &str) -> String {
        format!("{PACKAGE}_{debian_version}_{}.deb", self.arch)
    }
}

/// The usual multiarch tuple of a Debian architecture (the fallback of [`Target::host`]).
fn multiarch_of(arch: &str) -> Option<&'static str> {
    Some(match arch {
        "amd64" => "x86_64-linux-gnu",
        "arm64" => "aarch64-linux-gnu",
        "i386" => "i386-linux-gnu",
        "armhf" => "arm-linux-gnueabihf",
        "armel" => "arm-linux-gnueabi",
        "ppc64el" => "powerpc64le-linux-gnu",
        "s390x" => "s390x-linux-gnu",
        "riscv64" => "riscv64-linux-gnu",
        "loong64" => "loongarch64-linux-gnu",
        _ => return None,
    })
}

/// Runs a tool, saying clearly which package provides it when it is missing.
fn run_tool(tool: &str, command: &mut Command) -> Result<Output> {
    match command.output() {
        Ok(output) => Ok(output),
        Err(err) if err.kind() == std::io::ErrorKind::NotFound => bail!(
            "`{tool}` is not installed: `cargo xtask package` builds the Debian package with \
             dpkg's own tools, on Debian or Ubuntu (`apt-get install dpkg{}`)",
            if tool == "dpkg-architecture" {
                "-dev"
            } else {
                ""
            }
        ),
        Err(err) => Err(err).with_context(|| format!("starting {command:?}")),
    }
}

/// Fails with the tool's output unless it succeeded.
fn check(command: &Command, output: &Output) -> Result<()> {
    if !output.status.success() {
        bail!(
            "{command:?} failed ({}):\n{}{}",
            output.status,
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
    }
    Ok(())
}

/// A tool's trimmed standard output, or an error if it is missing or fails.
fn tool_output(tool: &str, args: &[&str]) -> Result<String> {
    let mut command = Command::new(tool);
    command.args(args);
    let output = run_tool(tool, &mut command)?;
    check(&command, &output)?;
    Ok(String::from_utf8_lossy(&output.stdout).trim().to_owned())
}

/// The Debian form of a Cargo version: a pre-release (`1.2.0-rc.1`) sorts before its release
/// in Cargo, and with `~` in Debian (`1.2.0~rc.1`), where `-` would start a Debian revision.
pub fn debian_version(cargo_version: &str) -> Result<String> {
    let version = cargo_version.replace('-', "~");
    let valid = version.starts_with(|c: char| c.is_ascii_digit())
        && version
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '+' | '~'));
    if !valid {
        bail!("version {cargo_version:?} has no Debian form (digits, letters, `.`, `+`, `~`)");
    }
    Ok(version)
}

/// The maintainer: `DEBEMAIL` (and `DEBFULLNAME`) as Debian's tools read them, else the
/// project's.
fn maintainer() -> String {
    let var = |name| {
        std::env::var(name)
            .ok()
            .filter(|v: &String| !v.trim().is_empty())
    };
    match (var("DEBFULLNAME"), var("DEBEMAIL")) {
        (_, Some(email)) if email.contains('<') => email,
        (Some(name), Some(email)) => format!("{name} <{email}>"),
        (None, Some(email)) => format!("revz maintainers <{email}>"),
        (_, None) => DEFAULT_MAINTAINER.to_owned(),
    }
}

/// `DEBIAN/control`.
pub fn control(version: &str, arch: &str, maintainer: &str, installed_size_kib: u64) -> String {
    format!(
        "Package: {PACKAGE}\n\
         Version: {version}\n\
         Architecture: {arch}\n\
         Maintainer: {maintainer}\n\
         Installed-Size: {installed_size_kib}\n\
         Depends: libvulkan1\n\
         Section: libs\n\
         Priority: optional\n\
         Description: Vulkan layer rendering applications with a reversed depth buffer\n \
         revz is a Vulkan layer that makes an unmodified Vulkan application render\n \
         with a reversed depth buffer: complementary (finite reversed) or infinite\n \
         reversed-Z, with every piece of depth state that must follow (compare ops,\n \
         clears, bias, bounds, viewport depth ranges, resolves), and D16 or D24 depth\n \
         images promoted to float storage, where reversal gains its precision.\n \
         .\n \
         This package installs revz as an implicit layer that stays off until a\n \
         program is started with {enable}=1; {disable}=1 turns it off again.\n \
         REVZ_MODE (off, flip, complementary, infinite) and the other settings\n \
         described in the layer manifest configure it.\n",
        enable = manifest::ENABLE_VAR,
        disable = manifest::DISABLE_VAR,
    )
}

/// `usr/share/doc/<package>/copyright`, in Debian's machine-readable format.
fn copyright() -> String {
    // The stanzas below name Cargo.toml's license; a test keeps the two in step.
    let mit = "Permission is hereby granted, free of charge, to any person obtaining a copy of \
        this software and associated documentation files (the \"Software\"), to deal in the \
        Software without restriction, including without limitation the rights to use, copy, \
        modify, merge, publish, distribute, sublicense, and/or sell copies of the Software, and \
        to permit persons to whom the Software is furnished to do so, subject to the following \
        conditions:\n\
        .\n\
        The above copyright notice and this permission notice shall be included in all copies \
        or substantial portions of the Software.\n\
        .\n\
        THE SOFTWARE IS PROVIDED \"AS IS\", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR IMPLIED, \
        INCLUDING BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY, FITNESS FOR A \
        PARTICULAR PURPOSE AND NONINFRINGEMENT. IN NO EVENT SHALL THE AUTHORS OR COPYRIGHT \
        HOLDERS BE LIABLE FOR ANY CLAIM, DAMAGES OR OTHER LIABILITY, WHETHER IN AN ACTION OF \
        CONTRACT, TORT OR OTHERWISE, ARISING FROM, OUT OF OR IN CONNECTION WITH THE SOFTWARE OR \
        THE USE OR OTHER DEALINGS IN THE SOFTWARE.";
    let mut text = String::from(
        "Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/\n\
         Upstream-Name: revz\n\
         \n\
         Files: *\n\
         Copyright: the revz contributors\n\
         License: MIT or Apache-2.0\n\
         Comment: revz is dual-licensed: use it under either license.\n\
         \n\
         License: MIT\n",
    );
    for line in mit.lines() {
        let _ = writeln!(text, " {line}");
    }
    text.push_str(
        "\nLicense: Apache-2.0\n \
         On Debian systems, the full text of the Apache License, Version 2.0 can be\n \
         found in /usr/share/common-licenses/Apache-2.0.\n",
    );
    text
}

/// Builds the .deb of `library` (any file: nothing is built here) at Cargo version `version`
/// into `out_dir`, with the manifest rendered from `root`'s template; returns its path,
/// `<out_dir>/<package>_<version>_<arch>.deb`.
pub fn build_deb(root: &Path, library: &Path, version: &str, out_dir: &Path) -> Result<PathBuf> {
    let target = Target::host()?;
    let debian_version = debian_version(version)?;
    let template_path = root.join(manifest::TEMPLATE);
    let template = std::fs::read_to_string(&template_path)
        .with_context(|| format!("reading {}", template_path.display()))?;
    let installed_library = target.installed_library();
    let manifest_text = manifest::render(&template, &installed_library, version, Kind::Implicit)?;
    let library_bytes =
        std::fs::read(library).with_context(|| format!("reading {}", library.display()))?;

    // The package's files, relative to `/`.
    let files: [(PathBuf, Vec<u8>); 3] = [
        (
            installed_library
                .strip_prefix("/")
                .expect("an absolute path")
                .to_path_buf(),
            library_bytes,
        ),
        (
            Path::new(IMPLICIT_LAYER_DIR).join(manifest::FILE_NAME),
            manifest_text.into_bytes(),
        ),
        (
            Path::new("usr/share/doc").join(PACKAGE).join("copyright"),
            copyright().into_bytes(),
        ),
    ];

    std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
    let deb = out_dir.join(target.file_name(&debian_version));
    let stage = out_dir.join(format!(".{PACKAGE}.staging"));
    let result = stage_and_build(&stage, &files, &target, &debian_version, &deb);
    let _ = std::fs::remove_dir_all(&stage);
    result?;
    Ok(deb)
}

/// Lays out `files` and `DEBIAN/` under `stage`, then has dpkg-deb build `deb` from it.
fn stage_and_build(
    stage: &Path,
    files: &[(PathBuf, Vec<u8>)],
    target: &Target,
    debian_version: &str,
    deb: &Path,
) -> Result<()> {
    match std::fs::remove_dir_all(stage) {
        Ok(()) => {}
        Err(err) if err.kind() == std::io::ErrorKind::NotFound => {}
        Err(err) => return Err(err).with_context(|| format!("removing {}", stage.display())),
    }
    for (relative, bytes) in files {
        let path = stage.join(relative);
        let dir = path.parent().expect("a file in a directory");
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
    }
    // Sizes as dpkg-gencontrol counts them: each file rounded up to KiB, 1 KiB per directory.
    let (files_kib, dirs) = tree_usage(stage)?;
    // The root of the tree is `/`, which the package does not add.
    let installed_size = files_kib + dirs - 1;

    let mut md5sum = Command::new("md5sum");
    md5sum.current_dir(stage).arg("--");
    md5sum.args(files.iter().map(|(relative, _)| relative));
    let sums = run_tool("md5sum", &mut md5sum)?;
    check(&md5sum, &sums)?;

    let debian = stage.join("DEBIAN");
    std::fs::create_dir(&debian).with_context(|| format!("creating {}", debian.display()))?;
    std::fs::write(debian.join("md5sums"), &sums.stdout)?;
    let control_text = control(debian_version, &target.arch, &maintainer(), installed_size);
    std::fs::write(debian.join("control"), control_text)?;
    // Whatever the umask: 0755 directories and 0644 files (the library too, as Debian ships
    // shared libraries), owned by root in the archive (--root-owner-group).
    normalize_modes(stage)?;

    let mut dpkg_deb = Command::new("dpkg-deb");
    dpkg_deb
        .arg("--root-owner-group")
        .arg("--build")
        .arg(stage)
        .arg(deb);
    let output = run_tool("dpkg-deb", &mut dpkg_deb)?;
    check(&dpkg_deb, &output)
}

/// The KiB the files under `dir` take, each rounded up, and the number of directories,
/// `dir` included.
fn tree_usage(dir: &Path) -> Result<(u64, u64)> {
    let (mut kib, mut dirs) = (0, 1);
    for entry in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let entry = entry?;
        if entry.file_type()?.is_dir() {
            let (sub_kib, sub_dirs) = tree_usage(&entry.path())?;
            kib += sub_kib;
            dirs += sub_dirs;
        } else {
            kib += entry.metadata()?.len().div_ceil(1024);
        }
    }
    Ok((kib, dirs))
}

/// Sets 0755 on `dir` and every directory under it, 0644 on every file.
fn normalize_modes(dir: &Path) -> Result<()> {
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o755))?;
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        if entry.file_type()?.is_dir() {
            normalize_modes(&entry.path())?;
        } else {
            std::fs::set_permissions(entry.path(), std::fs::Permissions::from_mode(0o644))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::Value;

    /// A fresh directory under the system's temporary directory, removed when dropped.
    struct Scratch(PathBuf);

    impl Scratch {
        fn new(name: &str) -> Scratch {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap()
                .as_nanos();
            let dir = std::env::temp_dir()
                .join(format!("revz-xtask-{name}-{}-{nanos}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            Scratch(dir)
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn workspace_root() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .unwrap()
            .to_path_buf()
    }

    /// Runs a dpkg tool, panicking with its output unless it succeeds; returns its stdout.
    fn dpkg_tool(tool: &str, args: &[&std::ffi::OsStr]) -> String {
        let mut command = Command::new(tool);
        command.args(args);
        let output = run_tool(tool, &mut command).unwrap_or_else(|err| panic!("{err:#}"));
        check(&command, &output).unwrap_or_else(|err| panic!("{err:#}"));
        String::from_utf8(output.stdout).unwrap()
    }

    #[test]
    fn control_file_names_package_version_architecture_and_dependency() {
        let text = control("1.2.0~rc.1", "arm64", "A Maintainer <a@example.org>", 1234);
        let fields: Vec<(&str, &str)> = text
            .lines()
            .filter(|line| !line.starts_with(' '))
            .map(|line| line.split_once(": ").expect("a `Field: value` line"))
            .collect();
        let names: Vec<&str> = fields.iter().map(|(name, _)| *name).collect();
        assert_eq!(
            names,
            [
                "Package",
                "Version",
                "Architecture",
                "Maintainer",
                "Installed-Size",
                "Depends",
                "Section",
                "Priority",
                "Description"
            ]
        );
        let field = |name| fields.iter().find(|(n, _)| *n == name).unwrap().1;
        assert_eq!(field("Package"), PACKAGE);
        assert_eq!(field("Version"), "1.2.0~rc.1");
        assert_eq!(field("Architecture"), "arm64");
        assert_eq!(field("Maintainer"), "A Maintainer <a@example.org>");
        assert_eq!(field("Installed-Size"), "1234");
        assert_eq!(field("Depends"), "libvulkan1");
        assert_eq!(field("Section"), "libs");
        assert_eq!(field("Priority"), "optional");
        // The long description: continuation lines of at most 80 columns, `.` for a blank
        // line, naming the toggles.
        let long: Vec<&str> = text.lines().filter(|l| l.starts_with(' ')).collect();
        assert!(long.len() > 3);
        assert!(long.iter().all(|l| l.len() <= 80 && l.trim() != ""));
        assert!(long.contains(&" ."));
        assert!(text.contains("ENABLE_REVZ=1") && text.contains("DISABLE_REVZ=1"));
        assert!(text.ends_with('\n') && !text.ends_with("\n\n"));
    }

    #[test]
    fn debian_versions_sort_pre_releases_before_releases() {
        assert_eq!(debian_version("0.1.0").unwrap(), "0.1.0");
        assert_eq!(debian_version("1.2.0-rc.1").unwrap(), "1.2.0~rc.1");
        assert_eq!(debian_version("1.2.0+build.5").unwrap(), "1.2.0+build.5");
        assert!(debian_version("v1").is_err());
        assert!(debian_version("1.0 beta").is_err());
    }

    #[test]
    fn multiarch_tuples_of_common_architectures() {
        assert_eq!(multiarch_of("amd64"), Some("x86_64-linux-gnu"));
        assert_eq!(multiarch_of("arm64"), Some("aarch64-linux-gnu"));
        assert_eq!(multiarch_of("hurd-i386"), None);
        let target = Target {
            arch: "arm64".into(),
            multiarch: "aarch64-linux-gnu".into(),
        };
        assert_eq!(
            target.installed_library(),
            Path::new("/usr/lib/aarch64-linux-gnu/libVkLayer_revz.so")
        );
        assert_eq!(
            target.file_name("0.1.0"),
            "revz-vulkan-layer_0.1.0_arm64.deb"
        );
        assert_eq!(apt_argument(Path::new("x.deb")), "./x.deb");
        assert_eq!(apt_argument(Path::new("target/x.deb")), "target/x.deb");
    }

    #[test]
    fn copyright_follows_the_cargo_license() {
        assert_eq!(
            env!("CARGO_PKG_LICENSE"),
            "MIT OR Apache-2.0",
            "the license changed: update copyright() to match"
        );
        let text = copyright();
        assert!(text.contains("License: MIT or Apache-2.0\n"));
        assert!(text.contains("\nLicense: MIT\n") && text.contains("\nLicense: Apache-2.0\n"));
        // Stanzas are separated by one empty line; every other line is a field or continues one.
        assert!(text
            .lines()
            .all(|l| l.is_empty() || l.starts_with(' ') || l.contains(": ")));
    }

    /// Builds the package from a stand-in library, installs it with dpkg into a scratch root
    /// (as root or not), checks what landed where, then removes it.
    #[test]
    fn deb_installs_library_and_implicit_manifest_into_a_scratch_root() {
        let scratch = Scratch::new("package");
        let library = scratch.0.join("build").join(LIBRARY_NAME);
        std::fs::create_dir_all(library.parent().unwrap()).unwrap();
        let bytes = b"\x7fELF stand-in for the layer, from xtask's package test\n";
        std::fs::write(&library, bytes).unwrap();
        let version = env!("CARGO_PKG_VERSION");

        let deb = build_deb(&workspace_root(), &library, version, &scratch.0.join("out"))
            .unwrap_or_else(|err| panic!("{err:#}"));
        let target = Target::host().unwrap();
        let debian_version = debian_version(version).unwrap();
        assert_eq!(
            deb.file_name().unwrap().to_str().unwrap(),
            format!("{PACKAGE}_{debian_version}_{}.deb", target.arch)
        );
        assert!(deb.is_file());
        assert!(!scratch
            .0
            .join("out")
            .join(format!(".{PACKAGE}.staging"))
            .exists());

        // What dpkg-deb says is in it.
        let fields = dpkg_tool(
            "dpkg-deb",
            &[
                "--field".as_ref(),
                deb.as_os_str(),
                "Package".as_ref(),
                "Version".as_ref(),
                "Architecture".as_ref(),
                "Depends".as_ref(),
            ],
        );
        assert_eq!(
            fields,
            format!(
                "Package: {PACKAGE}\nVersion: {debian_version}\nArchitecture: {}\n\
                 Depends: libvulkan1\n",
                target.arch
            )
        );
        let info = dpkg_tool("dpkg-deb", &["--info".as_ref(), deb.as_os_str()]);
        assert!(
            info.contains(" control") && info.contains(" md5sums"),
            "{info}"
        );
        let contents = dpkg_tool("dpkg-deb", &["--contents".as_ref(), deb.as_os_str()]);
        let installed_library = target.installed_library();
        let manifest_path = Path::new("/")
            .join(IMPLICIT_LAYER_DIR)
            .join(manifest::FILE_NAME);
        let copyright_path = format!("/usr/share/doc/{PACKAGE}/copyright");
        let mut listed = Vec::new();
        for line in contents.lines() {
            // `drwxr-xr-x root/root 0 2024-01-01 00:00 ./usr/`
            let columns: Vec<&str> = line.split_whitespace().collect();
            assert_eq!(columns.len(), 6, "{line}");
            assert_eq!(columns[1], "root/root", "{line}");
            let path = columns[5].trim_start_matches('.');
            let mode = if path.ends_with('/') {
                "drwxr-xr-x"
            } else {
                "-rw-r--r--"
            };
            assert_eq!(columns[0], mode, "{line}");
            listed.push(path.to_owned());
        }
        for path in [
            installed_library.to_str().unwrap(),
            manifest_path.to_str().unwrap(),
            &copyright_path,
        ] {
            assert!(listed.iter().any(|p| p == path), "{path} in {contents}");
        }
        let md5sums = dpkg_tool(
            "dpkg-deb",
            &["--info".as_ref(), deb.as_os_str(), "md5sums".as_ref()],
        );
        assert_eq!(md5sums.lines().count(), 3, "{md5sums}");

        // Install it into an empty scratch root with dpkg itself.
        let root = scratch.0.join("root");
        let admin = root.join("var/lib/dpkg");
        for dir in ["info", "updates", "triggers"] {
            std::fs::create_dir_all(admin.join(dir)).unwrap();
        }
        std::fs::write(admin.join("status"), "").unwrap();
        let mut root_arg = std::ffi::OsString::from("--root=");
        root_arg.push(&root);
        let dpkg = |action: &[&std::ffi::OsStr]| {
            let mut args: Vec<&std::ffi::OsStr> = vec![
                &root_arg,
                "--log=/dev/null".as_ref(),
                "--force-not-root".as_ref(),
                "--force-bad-path".as_ref(),
                "--force-depends".as_ref(),
                "--force-script-chrootless".as_ref(),
            ];
            args.extend_from_slice(action);
            dpkg_tool("dpkg", &args)
        };
        dpkg(&["--install".as_ref(), deb.as_os_str()]);

        let in_root = |path: &Path| root.join(path.strip_prefix("/").unwrap());
        assert_eq!(std::fs::read(in_root(&installed_library)).unwrap(), bytes);
        let text = std::fs::read_to_string(in_root(&manifest_path)).unwrap();
        let json: Value = serde_json::from_str(&text).unwrap();
        let layer = &json["layer"];
        assert_eq!(layer["name"], "VK_LAYER_REVZ_reverse_z");
        assert_eq!(layer["library_path"], installed_library.to_str().unwrap());
        let library_path = Path::new(layer["library_path"].as_str().unwrap());
        assert!(library_path.is_absolute());
        assert!(in_root(library_path).is_file());
        assert_eq!(layer["enable_environment"]["ENABLE_REVZ"], "1");
        assert_eq!(layer["disable_environment"]["DISABLE_REVZ"], "1");
        assert_eq!(
            layer["description"],
            format!("revz {version}: renders unmodified applications with a reversed depth buffer")
        );

        let mut admin_arg = std::ffi::OsString::from("--admindir=");
        admin_arg.push(&admin);
        let status = dpkg_tool(
            "dpkg-query",
            &[
                &admin_arg,
                "--show".as_ref(),
                "--showformat=${Status} ${Version}".as_ref(),
                PACKAGE.as_ref(),
            ],
        );
        assert_eq!(status, format!("install ok installed {debian_version}"));
        let files = dpkg_tool(
            "dpkg-query",
            &[&admin_arg, "--listfiles".as_ref(), PACKAGE.as_ref()],
        );
        for path in [&installed_library, &manifest_path] {
            assert!(files.lines().any(|l| Path::new(l) == path), "{files}");
        }

        // And removing it takes both away.
        dpkg(&["--remove".as_ref(), PACKAGE.as_ref()]);
        assert!(!in_root(&installed_library).exists());
        assert!(!in_root(&manifest_path).exists());
    }
}
