//! `vk_layer_settings.txt`: the settings file Vulkan Configurator writes for every layer.
//!
//! Lines are `revz_reverse_z.<setting> = <value>` (the layer name without `VK_LAYER_`, in lower
//! case, as the Vulkan Layer Settings library spells it); `#` starts a comment, and lines for
//! other layers are not ours to judge. The file is `$VK_LAYER_SETTINGS_PATH` (or
//! `vk_layer_settings.txt` inside it when it is a directory), else `vk_layer_settings.txt` in the
//! working directory.

use std::path::{Path, PathBuf};

use super::{setting_names, Resolved, SettingSpec, Value};

/// The environment variable Vulkan Configurator sets.
pub const PATH_VAR: &str = "VK_LAYER_SETTINGS_PATH";
/// The file name the settings library looks for.
pub const FILE_NAME: &str = "vk_layer_settings.txt";
/// The prefix of revz's lines.
pub const PREFIX: &str = "revz_reverse_z.";

/// Where the settings file is, and whether the user named it (`VK_LAYER_SETTINGS_PATH`).
/// `is_dir` tells whether a path is a directory (the file system in production).
pub fn locate(
    env: &dyn Fn(&str) -> Option<String>,
    is_dir: &dyn Fn(&Path) -> bool,
) -> (PathBuf, bool) {
    match env(PATH_VAR).filter(|p| !p.is_empty()) {
        Some(path) if is_dir(Path::new(&path)) => (Path::new(&path).join(FILE_NAME), true),
        Some(path) => (PathBuf::from(path), true),
        None => (PathBuf::from(FILE_NAME), false),
    }
}

/// Applies revz's lines of the settings file `text` (read from `path`) to `resolved`.
pub fn apply(path: &Path, text: &str, resolved: &mut Resolved) {
    let mut any = false;
    for (index, line) in text.lines().enumerate() {
        let line = line.trim();
        let Some(rest) = line.strip_prefix(PREFIX) else {
            continue;
        };
        any = true;
        let at = format!("{}:{}", path.display(), index + 1);
        let Some((name, value)) = rest.split_once('=') else {
            resolved.warnings.push(format!(
                "{at}: expected '{PREFIX}<setting> = <value>'; line ignored"
            ));
            continue;
        };
        let name = name.trim();
        let Some(spec) = SettingSpec::named(name) else {
            resolved.warnings.push(format!(
                "{at}: unknown setting '{name}' (settings: {})",
                setting_names()
            ));
            continue;
        };
        let value = Value::Text(value.trim().to_owned());
        resolved.apply(spec, &value, at.clone(), &at);
    }
    if any {
        resolved.notes.push(format!("{}", path.display()));
    }
}
