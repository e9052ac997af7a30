//! Layer manifests: the templates in `manifests/` rendered to point at a built library.
//!
//! The loader reads `library_path` as given, so the rendered copies hold an absolute path and
//! can be used from anywhere (`VK_ADD_LAYER_PATH=<dir>` for the explicit one, an
//! `implicit_layer.d` directory for the implicit one).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// The manifest's file name, the same for both variants.
pub const FILE_NAME: &str = "VkLayer_revz.json";

/// Which manifest: enabled on request, or on by default with enable/disable variables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Explicit,
    Implicit,
}

impl Kind {
    pub const ALL: [Kind; 2] = [Kind::Explicit, Kind::Implicit];

    fn template(self) -> &'static str {
        match self {
            Kind::Explicit => "VkLayer_revz.json.in",
            Kind::Implicit => "VkLayer_revz_implicit.json.in",
        }
    }

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

/// Fills a template's placeholders.
pub fn render(template: &str, library: &Path, version: &str) -> String {
    // JSON-escape the path: serde_json quotes it, and the template supplies the quotes.
    let escaped = serde_json::to_string(&library.to_string_lossy()).expect("a string serializes");
    template
        .replace("@LIBRARY_PATH@", &escaped[1..escaped.len() - 1])
        .replace(
            "@IMPLEMENTATION_VERSION@",
            &implementation_version(version).to_string(),
        )
        .replace("@VERSION@", version)
}

/// Renders both manifests for `library` under `out`; returns the explicit manifest's directory.
pub fn write_all(templates: &Path, library: &Path, version: &str, out: &Path) -> Result<PathBuf> {
    for kind in Kind::ALL {
        let template_path = templates.join(kind.template());
        let template = std::fs::read_to_string(&template_path)
            .with_context(|| format!("reading {}", template_path.display()))?;
        let dir = kind.dir(out);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join(FILE_NAME);
        std::fs::write(&path, render(&template, library, version))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(Kind::Explicit.dir(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn templates() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../manifests")
    }

    #[test]
    fn rendered_manifests_are_valid_json_naming_the_library() {
        let library = Path::new("/opt/re\"vz/libVkLayer_revz.so");
        for kind in Kind::ALL {
            let template = std::fs::read_to_string(templates().join(kind.template())).unwrap();
            let text = render(&template, library, "1.2.3");
            let json: serde_json::Value = serde_json::from_str(&text).unwrap();
            let layer = &json["layer"];
            assert_eq!(layer["name"], "VK_LAYER_REVZ_reverse_z");
            assert_eq!(layer["library_path"], "/opt/re\"vz/libVkLayer_revz.so");
            assert_eq!(layer["implementation_version"], "4202499");
            let implicit = kind == Kind::Implicit;
            assert_eq!(
                layer["enable_environment"]["ENABLE_REVZ"].as_str() == Some("1"),
                implicit
            );
            assert_eq!(
                layer["disable_environment"]["DISABLE_REVZ"].as_str() == Some("1"),
                implicit
            );
        }
    }
}
