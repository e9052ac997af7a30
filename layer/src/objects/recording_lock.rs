//! The lock around a command buffer's recording state ([`RecordingLock`]): taken on every
//! push, bind and settle, so it costs one atomic exchange to take and one store to release.
//!
//! Why not `std::sync::Mutex`: by Vulkan's rules one thread records a command buffer at a time
//! (its commands are externally synchronized), so the lock is never contended in a valid
//! application, and the standard mutex's extra work per use (its poisoning checks on taking
//! and releasing, the waiter check on release) was about 20 instructions of a push's few
//! hundred (micro child, callgrind). Poisoning buys nothing here either: every user ignored
//! it (a panic in a hook is caught at the boundary, and the state stays usable).
//!
//! Contended anyway (an application recording one command buffer from two threads at once,
//! which is invalid usage), a taker spins briefly and then yields until the holder releases:
//! slower, never unsound. Taking it again on the thread that holds it deadlocks, as the
//! standard mutex may; revz never does (a hook takes it once and calls down after releasing).

use std::cell::UnsafeCell;
use std::sync::atomic::{AtomicBool, Ordering};

/// A lock around `T` for state that one thread uses at a time (module docs).
pub struct RecordingLock<T> {
    locked: AtomicBool,
    value: UnsafeCell<T>,
}

// SAFETY: the value is reached only through a guard, and at most one guard exists at a time
// (`locked` is taken with an acquiring exchange and released with a releasing store), as for
// `std::sync::Mutex`.
unsafe impl<T: Send> Sync for RecordingLock<T> {}

impl<T> RecordingLock<T> {
    pub const fn new(value: T) -> Self {
        RecordingLock {
            locked: AtomicBool::new(false),
            value: UnsafeCell::new(value),
        }
    }

    /// Takes the lock, waiting where another thread holds it.
    #[inline]
    pub fn lock(&self) -> RecordingGuard<'_, T> {
        if self.locked.swap(true, Ordering::Acquire) {
            self.wait_for_release();
        }
        RecordingGuard { lock: self }
    }

    /// Takes the lock where no one holds it.
    pub fn try_lock(&self) -> Option<RecordingGuard<'_, T>> {
        // A guard only where the exchange took the lock: dropping one releases it.
        if self.locked.swap(true, Ordering::Acquire) {
            None
        } else {
            Some(RecordingGuard { lock: self })
        }
    }

    /// The contended path of [`Self::lock`] (invalid usage by the application): spins a
    /// little, then yields the thread, until the exchange takes the lock.
    #[cold]
    #[inline(never)]
    fn wait_for_release(&self) {
        let mut spins = 0u32;
        loop {
            while self.locked.load(Ordering::Relaxed) {
                if spins < 100 {
                    spins += 1;
                    std::hint::spin_loop();
                } else {
                    std::thread::yield_now();
                }
            }
            if !self.locked.swap(true, Ordering::Acquire) {
                return;
            }
        }
    }
}

impl<T: std::fmt::Debug> std::fmt::Debug for RecordingLock<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut out = f.debug_struct("RecordingLock");
        match self.try_lock() {
            Some(guard) => out.field("value", &&*guard),
            None => out.field("value", &format_args!("<locked>")),
        };
        out.finish()
    }
}

/// The held [`RecordingLock`]; releases it when dropped (unwinding included).
pub struct RecordingGuard<'a, T> {
    lock: &'a RecordingLock<T>,
}

impl<T> std::ops::Deref for RecordingGuard<'_, T> {
    type Target = T;
    #[inline]
    fn deref(&self) -> &T {
        // SAFETY: this guard holds the lock: no other reference to the value exists.
        unsafe { &*self.lock.value.get() }
    }
}

impl<T> std::ops::DerefMut for RecordingGuard<'_, T> {
    #[inline]
    fn deref_mut(&mut self) -> &mut T {
        // SAFETY: this guard holds the lock, and `&mut self` makes this the only reference
        // through it.
        unsafe { &mut *self.lock.value.get() }
    }
}

impl<T> Drop for RecordingGuard<'_, T> {
    #[inline]
    fn drop(&mut self) {
        self.lock.locked.store(false, Ordering::Release);
    }
}

impl<T: std::fmt::Debug> std::fmt::Debug for RecordingGuard<'_, T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        (**self).fmt(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn one_guard_at_a_time() {
        let lock = RecordingLock::new(1);
        let mut guard = lock.lock();
        *guard += 1;
        // Asked while held (twice: a failed try must not release it).
        assert!(lock.try_lock().is_none());
        assert!(lock.try_lock().is_none());
        assert_eq!(format!("{lock:?}"), "RecordingLock { value: <locked> }");
        assert_eq!(format!("{lock:?}"), "RecordingLock { value: <locked> }");
        drop(guard);
        assert_eq!(*lock.try_lock().expect("released"), 2);
        assert_eq!(format!("{lock:?}"), "RecordingLock { value: 2 }");
    }

    #[test]
    fn a_panic_releases_it() {
        let lock = RecordingLock::new(0);
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let _guard = lock.lock();
            panic!("in a hook");
        }));
        assert!(caught.is_err());
        assert!(lock.try_lock().is_some());
    }

    /// Contended (invalid usage by an application, but never unsound): every increment of
    /// four threads lands.
    #[test]
    fn contended_takers_wait_their_turn() {
        let lock = Arc::new(RecordingLock::new(0u64));
        let threads: Vec<_> = (0..4)
            .map(|_| {
                let lock = Arc::clone(&lock);
                std::thread::spawn(move || {
                    for _ in 0..10_000 {
                        *lock.lock() += 1;
                    }
                })
            })
            .collect();
        for thread in threads {
            thread.join().expect("no panic");
        }
        assert_eq!(*lock.lock(), 40_000);
    }
}
