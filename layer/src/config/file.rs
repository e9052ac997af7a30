//! The config file: defaults and per-application sections, in TOML.
//!
//! ```toml
//! mode = "complementary"          # top level: defaults for every application
//! log = "warn"
//!
//! [[application]]                 # applied when every match key given here matches
//! executable = "vkcube"           # executable file name
//! mode = "infinite"
//!
//! [[application]]
//! engine_name = "MyEngine"        # VkApplicationInfo::pEngineName (also: application_name)
//! mode = "off"
//! ```
//!
//! The file is found through `REVZ_CONFIG`, else `$XDG_CONFIG_HOME/revz/revz.toml`, else
//! `$HOME/.config/revz/revz.toml`. It can only set settings: it cannot make the layer read any
//! other file, and the only file it can make the layer write is the `log_file` it names.
//! Every problem is one warning with the file, the line and what is accepted; the rest of the
//! file still applies. A file that is not TOML at all is ignored as a whole.

use std::path::{Path, PathBuf};

use toml_edit::{Document, Item, Table};

use super::{setting_names, AppIdentity, Key, Resolved, SettingSpec, Settings, Value};

/// The environment variable naming the config file.
pub const PATH_VAR: &str = "REVZ_CONFIG";
/// The name of the array of per-application tables.
pub const APPLICATION_SECTION: &str = "application";
/// The keys that select which applications a section applies to.
pub const MATCH_KEYS: [&str; 3] = ["executable", "application_name", "engine_name"];

/// Where the config file is, and whether the user named it explicitly (`REVZ_CONFIG`).
pub fn locate(env: &dyn Fn(&str) -> Option<String>) -> Option<(PathBuf, bool)> {
    let non_empty = |name: &str| env(name).filter(|v| !v.is_empty());
    if let Some(path) = non_empty(PATH_VAR) {
        return Some((PathBuf::from(path), true));
    }
    let config_home = non_empty("XDG_CONFIG_HOME")
        .map(PathBuf::from)
        .or_else(|| non_empty("HOME").map(|home| Path::new(&home).join(".config")))?;
    Some((config_home.join("revz").join("revz.toml"), false))
}

/// The largest config file the layer reads: anything bigger is not a settings file.
const MAX_FILE_SIZE: u64 = 1 << 20;

/// Reads a config file from disk.
pub fn read(path: &Path) -> std::io::Result<String> {
    use std::io::Read;
    let mut text = String::new();
    let file = std::fs::File::open(path)?;
    if file.metadata()?.len() > MAX_FILE_SIZE {
        return Err(std::io::Error::other("larger than 1 MiB"));
    }
    file.take(MAX_FILE_SIZE).read_to_string(&mut text)?;
    Ok(text)
}

/// 1-based line of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

struct Reader<'a> {
    path: &'a Path,
    text: &'a str,
    warnings: Vec<String>,
}

impl Reader<'_> {
    fn warn_at(&mut self, span: Option<std::ops::Range<usize>>, message: String) {
        let location = match span {
            Some(span) => format!("{}:{}", self.path.display(), line_of(self.text, span.start)),
            None => self.path.display().to_string(),
        };
        self.warnings.push(format!("{location}: {message}"));
    }

    fn key_span(table: &Table, key: &str) -> Option<std::ops::Range<usize>> {
        table.key(key).and_then(|k| k.span())
    }

    /// Applies the settings of one table (the top level or one application section) to
    /// `settings`; match keys are skipped when `in_application`.
    /// Applies the settings of `table`; returns the keys applied.
    fn apply_table(
        &mut self,
        table: &Table,
        settings: &mut Settings,
        in_application: bool,
    ) -> Vec<Key> {
        let mut applied = Vec::new();
        for (key, item) in table.iter() {
            let span = Self::key_span(table, key);
            if in_application && MATCH_KEYS.contains(&key) {
                continue;
            }
            if !in_application && key == APPLICATION_SECTION {
                continue;
            }
            let Some(spec) = SettingSpec::named(key) else {
                let sections = if in_application {
                    format!("; match keys: {}", MATCH_KEYS.join(", "))
                } else {
                    format!("; sections: [[{APPLICATION_SECTION}]]")
                };
                self.warn_at(
                    span,
                    format!(
                        "unknown key '{key}' (settings: {}{sections})",
                        setting_names()
                    ),
                );
                continue;
            };
            let value = if let Some(text) = item.as_str() {
                Value::Text(text.to_owned())
            } else if let Some(flag) = item.as_bool() {
                Value::Bool(flag)
            } else {
                let before = settings.describe(spec.key);
                self.warn_at(
                    item.span().or(span),
                    format!(
                        "{key} must be a string or a boolean (expected {}); using {before}",
                        spec.accepted()
                    ),
                );
                continue;
            };
            match settings.apply(spec, &value) {
                Ok(()) => applied.push(spec.key),
                Err(problem) => {
                    // An unreadable mode is `off`, from here.
                    if spec.key == Key::Mode {
                        applied.push(spec.key);
                    }
                    self.warn_at(item.span().or(span), problem)
                }
            }
        }
        applied
    }

    /// Whether an application section applies to `app`; `None` if the section is unusable.
    fn section_matches(&mut self, table: &Table, app: &AppIdentity) -> Option<bool> {
        let mut any = false;
        let mut all = true;
        for key in MATCH_KEYS {
            let Some(item) = table.get(key) else { continue };
            let Some(wanted) = item.as_str() else {
                self.warn_at(
                    item.span().or(Self::key_span(table, key)),
                    format!("{key} must be a string; this section is ignored"),
                );
                return None;
            };
            any = true;
            let actual = match key {
                "executable" => &app.executable,
                "application_name" => &app.application_name,
                _ => &app.engine_name,
            };
            all &= actual.as_deref() == Some(wanted);
        }
        if !any {
            self.warn_at(
                table.span(),
                format!(
                    "this [[{APPLICATION_SECTION}]] has no match key (one of: {}); it is ignored",
                    MATCH_KEYS.join(", ")
                ),
            );
            return None;
        }
        Some(all)
    }
}

/// Applies the config file `text` (read from `path`) to `resolved`.
pub fn apply(path: &Path, text: &str, app: &AppIdentity, resolved: &mut Resolved) {
    let document = match Document::parse(text) {
        Ok(document) => document,
        Err(err) => {
            let line = err.span().map_or(0, |span| line_of(text, span.start));
            let message = err.message().trim_end().replace('\n', " ");
            resolved.warnings.push(format!(
                "{}:{line}: not valid TOML ({message}); ignoring this file and using the defaults",
                path.display()
            ));
            return;
        }
    };
    let mut reader = Reader {
        path,
        text,
        warnings: Vec::new(),
    };
    let root = document.as_table();
    let origin = format!("config file {}", path.display());
    for key in reader.apply_table(root, &mut resolved.settings, false) {
        resolved.set_origin(key, origin.clone());
    }
    resolved.notes.push(origin.clone());

    match root.get(APPLICATION_SECTION) {
        None => {}
        Some(Item::ArrayOfTables(sections)) => {
            for section in sections.iter() {
                match reader.section_matches(section, app) {
                    Some(true) => {
                        let keys = reader.apply_table(section, &mut resolved.settings, true);
                        let line = section.span().map_or(0, |s| line_of(text, s.start));
                        let section = format!("[[{APPLICATION_SECTION}]] at line {line}");
                        for key in keys {
                            resolved.set_origin(key, format!("{origin}, {section}"));
                        }
                        resolved.notes.push(section);
                    }
                    // Still report the problems of sections that do not apply here.
                    Some(false) => {
                        let mut scratch = resolved.settings.clone();
                        reader.apply_table(section, &mut scratch, true);
                    }
                    None => {}
                }
            }
        }
        Some(other) => reader.warn_at(
            other.span().or(Reader::key_span(root, APPLICATION_SECTION)),
            format!(
                "'{APPLICATION_SECTION}' must be an array of tables, written [[{APPLICATION_SECTION}]]; \
                 it is ignored"
            ),
        ),
    }
    resolved.warnings.append(&mut reader.warnings);
}
