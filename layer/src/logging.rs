//! The layer's logger: silent unless `REVZ_LOG` asks for it.
//!
//! `REVZ_LOG=error|warn|info|debug|trace` sets the level; output goes to stderr, or appended to
//! `REVZ_LOG_FILE` when that is set. The layer is a `cdylib` with its own copy of `log`, so this
//! logger never collides with one the host application installs.

use std::fs::OpenOptions;
use std::io::Write;
use std::sync::Once;

use log::LevelFilter;

/// The variable holding the log level.
pub const LEVEL_VAR: &str = "REVZ_LOG";
/// The variable holding the log file path.
pub const FILE_VAR: &str = "REVZ_LOG_FILE";

static INIT: Once = Once::new();

/// Parses a `REVZ_LOG` value. `None` means the value was not understood.
pub fn parse_level(text: &str) -> Option<LevelFilter> {
    match text.trim().to_ascii_lowercase().as_str() {
        "off" | "none" | "0" => Some(LevelFilter::Off),
        "error" => Some(LevelFilter::Error),
        "warn" | "warning" => Some(LevelFilter::Warn),
        "info" => Some(LevelFilter::Info),
        "debug" => Some(LevelFilter::Debug),
        "trace" => Some(LevelFilter::Trace),
        _ => None,
    }
}

/// Installs the logger once per process. Later calls do nothing.
pub fn init() {
    INIT.call_once(|| {
        let requested = std::env::var(LEVEL_VAR).ok();
        let level = requested.as_deref().map(parse_level);
        let filter = match level {
            None => LevelFilter::Off,
            Some(Some(level)) => level,
            // Unknown text: the user wanted logs; warnings are the useful default.
            Some(None) => LevelFilter::Warn,
        };
        if filter == LevelFilter::Off {
            return;
        }

        let mut builder = env_logger::Builder::new();
        builder
            .filter_level(filter)
            .format(|out, record| writeln!(out, "[revz {}] {}", record.level(), record.args()));
        let mut file_problem = None;
        if let Ok(path) = std::env::var(FILE_VAR) {
            match OpenOptions::new().create(true).append(true).open(&path) {
                Ok(file) => {
                    builder.target(env_logger::Target::Pipe(Box::new(file)));
                }
                Err(err) => {
                    file_problem = Some(format!("{FILE_VAR}='{path}': {err}; logging to stderr"))
                }
            }
        }
        // Another logger cannot already be installed in this library's own `log`, but do not
        // fail the host application if it somehow is.
        if builder.try_init().is_err() {
            return;
        }
        if let Some(Some(_)) = level {
        } else if let Some(text) = requested {
            log::warn!(
                "{LEVEL_VAR}='{text}' is not a log level \
                 (expected one of: off, error, warn, info, debug, trace); using warn"
            );
        }
        if let Some(problem) = file_problem {
            log::warn!("{problem}");
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_parse() {
        assert_eq!(parse_level("info"), Some(LevelFilter::Info));
        assert_eq!(parse_level(" DEBUG "), Some(LevelFilter::Debug));
        assert_eq!(parse_level("warning"), Some(LevelFilter::Warn));
        assert_eq!(parse_level("loud"), None);
    }
}
