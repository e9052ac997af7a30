//! The layer's logger: silent unless the `log` setting asks for it.
//!
//! The level and destination come from the resolved settings of the first instance (a process
//! has one logger): stderr, or appended to the `log_file` setting. The layer is a `cdylib` with
//! its own copy of `log`, so this logger never collides with one the host application installs.
//!
//! With a depth profile (`report`), revz's warnings and errors are also kept, each once with a
//! count ([`warnings`]), whatever the log level: the profile lists them.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::Path;
use std::sync::{Mutex, Once, PoisonError};

use log::{LevelFilter, Log, Metadata, Record};

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

/// revz's warnings and errors so far, each once, with how many times it was logged (kept only
/// where [`init`] was asked to).
static WARNINGS: Mutex<Vec<(String, u64)>> = Mutex::new(Vec::new());
/// At most this many distinct warnings are kept.
const WARNINGS_KEPT: usize = 256;

/// The warnings and errors kept so far, with their counts.
pub fn warnings() -> Vec<(String, u64)> {
    WARNINGS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clone()
}

/// The logger: env_logger for what the level prints, and the kept warnings.
struct Logger {
    print: Option<env_logger::Logger>,
    keep_warnings: bool,
}

impl Log for Logger {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        ours(metadata.target())
            && ((self.keep_warnings && metadata.level() <= log::Level::Warn)
                || self.print.as_ref().is_some_and(|p| p.enabled(metadata)))
    }

    fn log(&self, record: &Record<'_>) {
        if !ours(record.target()) {
            return;
        }
        if self.keep_warnings && record.level() <= log::Level::Warn {
            let message = record.args().to_string();
            let mut kept = WARNINGS.lock().unwrap_or_else(PoisonError::into_inner);
            match kept.iter().position(|(m, _)| *m == message) {
                Some(index) => kept[index].1 += 1,
                None if kept.len() < WARNINGS_KEPT => kept.push((message, 1)),
                None => {}
            }
        }
        if let Some(print) = &self.print {
            print.log(record);
        }
    }

    fn flush(&self) {
        if let Some(print) = &self.print {
            print.flush();
        }
    }
}

/// Whether a record's target is this crate's (naga, which revz runs on application shaders,
/// logs through the same facade).
fn ours(target: &str) -> bool {
    target.split("::").next() == module_path!().split("::").next()
}

/// Installs the logger once per process; later calls do nothing. Returns a warning to log if
/// the log file could not be opened (the log then goes to stderr). `keep_warnings`: also keep
/// revz's warnings and errors for the depth profile, whatever `level`.
pub fn init(level: LevelFilter, file: Option<&Path>, keep_warnings: bool) -> Option<String> {
    let mut problem = None;
    INIT.call_once(|| {
        if level == LevelFilter::Off && !keep_warnings {
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
        let print = (level != LevelFilter::Off).then(|| builder.build());
        let max = if keep_warnings {
            level.max(LevelFilter::Warn)
        } else {
            level
        };
        // This library's own `log` cannot have another logger, but never fail the host for it.
        if log::set_boxed_logger(Box::new(Logger {
            print,
            keep_warnings,
        }))
        .is_ok()
        {
            log::set_max_level(max);
        }
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
