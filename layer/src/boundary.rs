//! The C boundary: no panic unwinds into the host application.
//!
//! Every exported or intercepted function runs its body through [`guarded`]. A panic is caught,
//! logged once per entry point (an application calls some of these millions of times), and the
//! entry point's fallback runs instead; fallbacks call down the chain with the caller's
//! original arguments whenever the next layer is known.

use std::any::Any;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// One entry point of the layer, for panic reporting.
#[derive(Debug)]
pub struct EntryPoint {
    name: &'static str,
    /// Logged at the first panic; later ones are counted (the depth profile's warnings).
    panicked: crate::logging::LogOnce,
}

impl EntryPoint {
    /// An entry point called `name` (the Vulkan command name).
    pub const fn new(name: &'static str) -> Self {
        EntryPoint {
            name,
            panicked: crate::logging::LogOnce::new(),
        }
    }

    fn report(&'static self, payload: &(dyn Any + Send)) {
        self.panicked.log(|| {
            let message = payload
                .downcast_ref::<&str>()
                .copied()
                .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
                .unwrap_or("(no message)");
            log::error!(
                "internal error in {}: {message}; the call was passed down unchanged \
                 (further errors in {} are not logged)",
                self.name,
                self.name
            );
        });
    }
}

/// Runs `body`; if it panics, reports the panic once for `entry` and returns `fallback()`.
///
/// `fallback` must not panic itself: it should do no more than call down the chain.
#[inline]
pub fn guarded<R>(
    entry: &'static EntryPoint,
    body: impl FnOnce() -> R,
    fallback: impl FnOnce() -> R,
) -> R {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(value) => value,
        Err(payload) => {
            // Logging itself must not unwind either.
            let _ = catch_unwind(AssertUnwindSafe(|| entry.report(payload.as_ref())));
            fallback()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    static ENTRY: EntryPoint = EntryPoint::new("vkTest");

    #[test]
    fn a_panic_runs_the_fallback_and_is_remembered() {
        let value = guarded(&ENTRY, || -> i32 { panic!("boom") }, || 7);
        assert_eq!(value, 7);
        assert!(ENTRY.panicked.occurred());
        // A second panic still falls back.
        assert_eq!(guarded(&ENTRY, || -> i32 { panic!("again") }, || 8), 8);
    }

    #[test]
    fn no_panic_returns_the_body_value() {
        static QUIET: EntryPoint = EntryPoint::new("vkQuiet");
        assert_eq!(guarded(&QUIET, || 1, || 2), 1);
        assert!(!QUIET.panicked.occurred());
    }
}
