//! The layer's logger: silent unless the `log` setting asks for it.
//!
//! The level and destination come from the resolved settings of the first instance (a process
//! has one logger): stderr, or appended to the `log_file` setting. The layer is a `cdylib` with
//! its own copy of `log`, so this logger never collides with one the host application installs.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::Path;
use std::sync::Once;

use log::LevelFilter;

static INIT: Once = Once::new();

/// Every accepted level name, for the settings table and warnings.
pub const LEVEL_NAMES: &[&str] = &["off", "error", "warn", "info", "debug", "trace"];

/// Parses a level name (case-insensitive). `None` means the text was not understood.
pub fn parse_level(text: &str) -> Option<LevelFilter> {
    match text.trim().to_ascii_lowercase().as_str() {
        "off" => Some(LevelFilter::Off),
        "error" => Some(LevelFilter::Error),
        "warn" | "warning" => Some(LevelFilter::Warn),
        "info" => Some(LevelFilter::Info),
        "debug" => Some(LevelFilter::Debug),
        "trace" => Some(LevelFilter::Trace),
        _ => None,
    }
}

/// Installs the logger once per process; later calls do nothing. Returns a warning to log if
/// the log file could not be opened (the log then goes to stderr).
pub fn init(level: LevelFilter, file: Option<&Path>) -> Option<String> {
    let mut problem = None;
    INIT.call_once(|| {
        if level == LevelFilter::Off {
            return;
        }
        let mut builder = env_logger::Builder::new();
        builder
            // Only revz's own records: naga (which revz runs on application shaders) logs
            // its own diagnostics through the same `log` facade.
            .filter_level(LevelFilter::Off)
            .filter_module(module_path!().split("::").next().unwrap_or_default(), level)
            .format(|out, record| writeln!(out, "[revz {}] {}", record.level(), record.args()));
        if let Some(path) = file {
            match OpenOptions::new().create(true).append(true).open(path) {
                Ok(file) => {
                    builder.target(env_logger::Target::Pipe(Box::new(file)));
                }
                Err(err) => {
                    problem = Some(format!(
                        "log_file {}: cannot be opened ({err}); logging to stderr",
                        path.display()
                    ));
                }
            }
        }
        // This library's own `log` cannot have another logger, but never fail the host for it.
        let _ = builder.try_init();
    });
    problem
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_level_name_parses() {
        for name in LEVEL_NAMES {
            assert!(parse_level(name).is_some(), "{name}");
        }
        assert_eq!(parse_level(" DEBUG "), Some(LevelFilter::Debug));
        assert_eq!(parse_level("loud"), None);
    }
}
