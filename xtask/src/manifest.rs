//! Layer manifests: the template in `manifests/` rendered to point at a built library.
//!
//! One template describes the layer and its settings; the explicit manifest is the template
//! filled in, and the implicit one adds the `enable_environment` / `disable_environment` pair
//! that implicit layers need. The loader reads `library_path` as given, so the rendered copies
//! hold an absolute path and can be used from anywhere (`VK_ADD_LAYER_PATH=<dir>` for the
//! explicit one, an `implicit_layer.d` directory for the implicit one).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde_json::{json, Value};

/// The manifest's file name, the same for both variants.
pub const FILE_NAME: &str = "VkLayer_revz.json";
/// The template, relative to the workspace root.
pub const TEMPLATE: &str = "manifests/VkLayer_revz.json.in";
/// The implicit layer's variables, in the style of other implicit layers.
pub const ENABLE_VAR: &str = "ENABLE_REVZ";
pub const DISABLE_VAR: &str = "DISABLE_REVZ";

/// Which manifest: enabled on request, or on by default with enable/disable variables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Explicit,
    Implicit,
}

impl Kind {
    pub const ALL: [Kind; 2] = [Kind::Explicit, Kind::Implicit];

    /// The directory under `out` where this kind's rendered manifest goes.
    pub fn dir(self, out: &Path) -> PathBuf {
        out.join(match self {
            Kind::Explicit => "explicit",
            Kind::Implicit => "implicit",
        })
    }
}

/// `major.minor.patch` packed the way `implementation_version` expects a single integer.
fn implementation_version(version: &str) -> u32 {
    let mut parts = version.split('.').map(|p| p.parse::<u32>().unwrap_or(0));
    let mut next = || parts.next().unwrap_or(0);
    (next() << 22) | (next() << 12) | next()
}

/// Fills the template's placeholders and makes the `kind` variant.
pub fn render(template: &str, library: &Path, version: &str, kind: Kind) -> Result<String> {
    // JSON-escape the path: serde_json quotes it, and the template supplies the quotes.
    let escaped = serde_json::to_string(&library.to_string_lossy())?;
    let text = template
        .replace("@LIBRARY_PATH@", &escaped[1..escaped.len() - 1])
        .replace(
            "@IMPLEMENTATION_VERSION@",
            &implementation_version(version).to_string(),
        )
        .replace("@VERSION@", version);
    let mut manifest: Value = serde_json::from_str(&text).context("the manifest template")?;
    if kind == Kind::Implicit {
        let layer = manifest["layer"]
            .as_object_mut()
            .context("the template has no \"layer\" object")?;
        layer.insert("enable_environment".into(), json!({ ENABLE_VAR: "1" }));
        layer.insert("disable_environment".into(), json!({ DISABLE_VAR: "1" }));
    }
    Ok(serde_json::to_string_pretty(&manifest)? + "\n")
}

/// Renders the `kind` manifest for `library` into `dir`; returns the manifest's path.
pub fn write(root: &Path, library: &Path, kind: Kind, dir: &Path) -> Result<PathBuf> {
    let template_path = root.join(TEMPLATE);
    let template = std::fs::read_to_string(&template_path)
        .with_context(|| format!("reading {}", template_path.display()))?;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let path = dir.join(FILE_NAME);
    let text = render(&template, library, env!("CARGO_PKG_VERSION"), kind)?;
    std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

/// Renders both manifests for `library` under `out`; returns the explicit manifest's directory.
pub fn write_all(root: &Path, library: &Path, out: &Path) -> Result<PathBuf> {
    for kind in Kind::ALL {
        write(root, library, kind, &kind.dir(out))?;
    }
    Ok(Kind::Explicit.dir(out))
}

/// The benchmark's counting layer (`tester/count-layer`): its manifest's template and name.
pub const COUNT_TEMPLATE: &str = "tester/count-layer/manifest.json.in";
pub const COUNT_FILE_NAME: &str = "VkLayer_revz_count.json";

/// Renders the counting layer's explicit manifest for `library` into `dir`.
pub fn write_count_layer(root: &Path, library: &Path, dir: &Path) -> Result<PathBuf> {
    let template_path = root.join(COUNT_TEMPLATE);
    let template = std::fs::read_to_string(&template_path)
        .with_context(|| format!("reading {}", template_path.display()))?;
    let escaped = serde_json::to_string(&library.to_string_lossy())?;
    let text = template.replace("@LIBRARY_PATH@", &escaped[1..escaped.len() - 1]);
    let _: Value = serde_json::from_str(&text).context("the counting layer's template")?;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let path = dir.join(COUNT_FILE_NAME);
    std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rendered_manifests_are_valid_json_naming_the_library() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let template = std::fs::read_to_string(root.join(TEMPLATE)).unwrap();
        let library = Path::new("/opt/re\"vz/libVkLayer_revz.so");
        for kind in Kind::ALL {
            let text = render(&template, library, "1.2.3", kind).unwrap();
            let json: Value = serde_json::from_str(&text).unwrap();
            let layer = &json["layer"];
            assert_eq!(layer["name"], "VK_LAYER_REVZ_reverse_z");
            assert_eq!(layer["library_path"], "/opt/re\"vz/libVkLayer_revz.so");
            assert_eq!(layer["implementation_version"], "4202499");
            assert!(layer["features"]["settings"].is_array());
            let implicit = kind == Kind::Implicit;
            assert_eq!(layer["enable_environment"][ENABLE_VAR] == "1", implicit);
            assert_eq!(layer["disable_environment"][DISABLE_VAR] == "1", implicit);
        }
    }
}
