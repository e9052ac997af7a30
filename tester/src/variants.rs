//! Renders "with and without the layer" from one tester invocation: this executable runs itself
//! again as a child process, once per [`Variant`], with the environment that injects revz in
//! the variant's mode (or no layer at all). The `report`, `conformance` and `bench` commands
//! compare variants measured in one run this way.
//!
//! The layer is found through the explicit manifest `cargo xtask build` writes next to this
//! executable (`<dir of revz-tester>/manifests/explicit`), or in the directory `--layer-dir`
//! names. The child gets a scrubbed environment: no layer or revz variable of the parent's
//! leaks into a variant.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};

/// The layer's name, as the manifest declares it.
pub const LAYER_NAME: &str = "VK_LAYER_REVZ_reverse_z";

/// Environment variables that would change what a child renders; removed before each run.
const SCRUBBED_ENV: &[&str] = &[
    "REVZ_MODE",
    "REVZ_LOG",
    "REVZ_LOG_FILE",
    "REVZ_CONFIG",
    "REVZ_FAR_CLIP",
    "REVZ_REVERSE_OBSERVABLE",
    "REVZ_COPY_VALUES",
    "REVZ_COMPARE_OP",
    "REVZ_PROMOTE_DEPTH_FORMATS",
    "REVZ_REPORT",
    "ENABLE_REVZ",
    "DISABLE_REVZ",
    "VK_INSTANCE_LAYERS",
    "VK_LOADER_LAYERS_ENABLE",
    "VK_LOADER_LAYERS_DISABLE",
    "VK_ADD_LAYER_PATH",
    "VK_LAYER_PATH",
];

/// One way of running the tester: without revz, or through it in one mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Variant {
    /// No layer at all: the reference.
    NoLayer,
    /// revz loaded in `off` mode (its cost when it passes everything through).
    Off,
    Flip,
    Complementary,
    Infinite,
}

impl Variant {
    /// Every variant, the reference first.
    pub const ALL: [Variant; 5] = [
        Variant::NoLayer,
        Variant::Off,
        Variant::Flip,
        Variant::Complementary,
        Variant::Infinite,
    ];

    /// The name reports use (`mode` column): `none` for no layer, else revz's mode name.
    pub fn name(self) -> &'static str {
        match self {
            Variant::NoLayer => "none",
            Variant::Off => "off",
            Variant::Flip => "flip",
            Variant::Complementary => "complementary",
            Variant::Infinite => "infinite",
        }
    }

    /// The `REVZ_MODE` of the variant; `None` when the layer is not loaded.
    pub fn mode(self) -> Option<&'static str> {
        match self {
            Variant::NoLayer => None,
            other => Some(other.name()),
        }
    }
}

/// Starts tester child processes for variants.
#[derive(Clone, Debug)]
pub struct Runner {
    exe: PathBuf,
    layer_dir: PathBuf,
}

impl Runner {
    /// Finds this executable and the layer's manifest directory (`layer_dir`, else the one
    /// `cargo xtask build` writes next to this executable).
    pub fn locate(layer_dir: Option<&Path>) -> Result<Runner> {
        let exe = std::env::current_exe().context("cannot find the tester's own executable")?;
        let layer_dir = match layer_dir {
            Some(dir) => dir.to_path_buf(),
            None => exe
                .parent()
                .context("the tester's executable has no directory")?
                .join("manifests/explicit"),
        };
        let manifest = layer_dir.join("VkLayer_revz.json");
        if !manifest.is_file() {
            bail!(
                "no revz layer manifest at {} (run `cargo xtask build`, or pass --layer-dir)",
                manifest.display()
            );
        }
        Ok(Runner { exe, layer_dir })
    }

    /// The directory of revz's explicit manifest (and the benchmark's counting layer's).
    pub fn layer_dir(&self) -> &Path {
        &self.layer_dir
    }

    /// A command running this tester with `args` as `variant`, with revz's settings `env`
    /// (pairs such as `("REVZ_REVERSE_OBSERVABLE", "copies")`) when the layer is loaded.
    pub fn command(&self, variant: Variant, args: &[&str], env: &[(&str, &str)]) -> Command {
        let mut command = Command::new(&self.exe);
        for name in SCRUBBED_ENV {
            command.env_remove(name);
        }
        command.args(args);
        if let Some(mode) = variant.mode() {
            command
                .env("VK_ADD_LAYER_PATH", &self.layer_dir)
                .env("VK_INSTANCE_LAYERS", LAYER_NAME)
                .env("REVZ_MODE", mode);
            for (name, value) in env {
                command.env(name, value);
            }
        }
        command
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variants_name_the_layer_modes() {
        assert_eq!(Variant::NoLayer.mode(), None);
        let modes: Vec<_> = Variant::ALL.iter().filter_map(|v| v.mode()).collect();
        assert_eq!(modes, ["off", "flip", "complementary", "infinite"]);
    }

    #[test]
    fn a_variant_runs_with_a_scrubbed_environment() {
        let runner = Runner {
            exe: PathBuf::from("/bin/true"),
            layer_dir: PathBuf::from("/layers"),
        };
        let command = runner.command(
            Variant::Infinite,
            &["--scene", "overlap"],
            &[("REVZ_FAR_CLIP", "keep")],
        );
        let envs: Vec<_> = command.get_envs().collect();
        let get = |name: &str| {
            envs.iter()
                .find(|(n, _)| *n == name)
                .and_then(|(_, v)| v.map(|v| v.to_string_lossy().into_owned()))
        };
        assert_eq!(get("REVZ_MODE").as_deref(), Some("infinite"));
        assert_eq!(get("REVZ_FAR_CLIP").as_deref(), Some("keep"));
        assert_eq!(get("VK_INSTANCE_LAYERS").as_deref(), Some(LAYER_NAME));
        let plain = runner.command(Variant::NoLayer, &[], &[("REVZ_FAR_CLIP", "keep")]);
        assert!(
            plain.get_envs().all(|(_, value)| value.is_none()),
            "no layer: only removals"
        );
    }
}
