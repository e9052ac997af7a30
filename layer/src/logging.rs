//! The layer's logger: silent unless the `log` setting asks for it.
//!
//! The level and destination come from the resolved settings of the first instance (a process
//! has one logger): stderr, or appended to the `log_file` setting. The layer is a `cdylib` with
//! its own copy of `log`, so this logger never collides with one the host application installs.
//!
//! With a depth profile (`report`), revz's warnings and errors are also kept, each once with a
//! count ([`warnings`]), whatever the log level: the profile lists them. A warning revz logs
//! only once ([`LogOnce`]) still counts each time its cause occurs.

use std::cell::Cell;
use std::fs::OpenOptions;
use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
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

/// Whether warnings are kept (a depth profile asked for them): later occurrences of a
/// [`LogOnce`] warning are counted only then.
static KEEPING: AtomicBool = AtomicBool::new(false);

thread_local! {
    /// The [`LogOnce`] whose first occurrence is being logged on this thread: the logger
    /// tells it where its warning was kept.
    static LOGGING_ONCE: Cell<Option<&'static LogOnce>> = const { Cell::new(None) };
}

/// A warning or error logged the first time its cause occurs (revz never floods the host's
/// log); later occurrences are only counted, into the depth profile's count of that warning.
/// Without a profile a later occurrence costs one load.
#[derive(Debug)]
pub struct LogOnce {
    once: Once,
    /// 1 + the warning's index in [`WARNINGS`] (0: not kept).
    kept: AtomicUsize,
}

impl LogOnce {
    pub const fn new() -> Self {
        LogOnce {
            once: Once::new(),
            kept: AtomicUsize::new(0),
        }
    }

    /// Runs `log` (which logs one record) the first time; counts the later times.
    pub fn log(&'static self, log: impl FnOnce()) {
        let mut first = false;
        self.once.call_once(|| {
            first = true;
            LOGGING_ONCE.with(|site| site.set(Some(self)));
            log();
            LOGGING_ONCE.with(|site| site.set(None));
        });
        if first || !KEEPING.load(Ordering::Relaxed) {
            return;
        }
        let index = self.kept.load(Ordering::Relaxed);
        if index > 0 {
            let mut kept = WARNINGS.lock().unwrap_or_else(PoisonError::into_inner);
            if let Some((_, count)) = kept.get_mut(index - 1) {
                *count += 1;
            }
        }
    }

    /// Whether its cause occurred.
    pub fn occurred(&self) -> bool {
        self.once.is_completed()
    }
}

impl Default for LogOnce {
    fn default() -> Self {
        Self::new()
    }
}

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
            keep_warning(record.args().to_string());
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

/// Keeps a warning for the depth profile: counted where it was kept before, and remembered by
/// the [`LogOnce`] logging it, if one is.
fn keep_warning(message: String) {
    let mut kept = WARNINGS.lock().unwrap_or_else(PoisonError::into_inner);
    let index = match kept.iter().position(|(m, _)| *m == message) {
        Some(index) => {
            kept[index].1 += 1;
            Some(index)
        }
        None if kept.len() < WARNINGS_KEPT => {
            kept.push((message, 1));
            Some(kept.len() - 1)
        }
        None => None,
    };
    if let (Some(index), Some(site)) = (index, LOGGING_ONCE.with(Cell::get)) {
        site.kept.store(index + 1, Ordering::Relaxed);
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
        KEEPING.store(keep_warnings, Ordering::Relaxed);
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

    #[test]
    fn a_warning_logged_once_counts_every_occurrence_where_warnings_are_kept() {
        static SITE: LogOnce = LogOnce::new();
        let message = "revz unit test: logged once, counted thrice";
        KEEPING.store(true, Ordering::Relaxed);
        let mut logged = 0;
        for _ in 0..3 {
            SITE.log(|| {
                logged += 1;
                keep_warning(message.to_owned());
            });
        }
        assert_eq!(logged, 1);
        assert!(SITE.occurred());
        let count = warnings()
            .into_iter()
            .find(|(m, _)| m == message)
            .map(|(_, count)| count);
        assert_eq!(count, Some(3));
    }
}
