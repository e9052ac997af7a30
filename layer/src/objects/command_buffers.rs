//! The command buffers revz tracks per process: what it keeps for each ([`CommandBufferEntry`]:
//! its device, its depth state behind a lock, its pass scope, its copies' scratch), and the
//! lookup on every recorded command, where a thread-local cache answers repeated lookups from
//! the thread that records (the usual case) without touching the shared table.

use super::recording_lock::{RecordingGuard, RecordingLock};
use super::*;

/// What revz keeps for one command buffer.
#[derive(Debug)]
pub struct CommandBufferEntry {
    pub device: Arc<DeviceState>,
    /// Secondary command buffers may inherit a render pass; primaries never do.
    pub secondary: bool,
    state: RecordingLock<CommandState>,
    /// Whether the state has depth state to send ([`CommandState::wants_settle`]), as it was
    /// when its lock was last released: a hook after which nothing is pending settles without
    /// taking the lock again (one load). Written only under the state's lock.
    settle_wanted: AtomicBool,
    /// Whether the state has a push shortcut ([`CommandState::has_push_shortcut`]), as it
    /// was when its lock was last released: a push tries the shortcut only where it may
    /// answer (a frame of a new camera per push never takes the lock for it). Written only
    /// under the state's lock.
    shortcut_ready: AtomicBool,
    pub scope: Mutex<PassScope>,
    /// Its pool's queue family can dispatch compute (converted copies need it).
    pub dispatchable: bool,
    /// Scratch buffers of converted copies and the compute state to restore after them.
    pub copies: Mutex<crate::depth_copy::scratch::CommandCopies>,
}

impl CommandBufferEntry {
    pub fn copies(&self) -> MutexGuard<'_, crate::depth_copy::scratch::CommandCopies> {
        self.copies.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The command buffer's depth state, locked (uncontended: Vulkan has one thread record a
    /// command buffer at a time).
    pub fn state(&self) -> StateGuard<'_> {
        StateGuard {
            state: self.state.lock(),
            settle_wanted: &self.settle_wanted,
            shortcut_ready: &self.shortcut_ready,
        }
    }

    /// [`CommandState::push_shortcut`]: the push followed without the full path where it
    /// changes nothing revz sends (callers ask [`Self::has_push_shortcut`] first, so that a
    /// push without one takes no lock). It changes nothing a settle reads, so it leaves
    /// [`Self::settle_wanted`] as it was; a shortcut it declines stays (the full path that
    /// follows refreshes or drops it).
    #[inline]
    pub fn push_shortcut(
        &self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        data: &[u8],
    ) -> Option<vk::ShaderStageFlags> {
        self.state
            .lock()
            .push_shortcut(layout, stages, offset, data)
    }

    /// Whether the state had a push shortcut when its lock was last released (a push may
    /// then try [`Self::push_shortcut`]).
    #[inline]
    pub fn has_push_shortcut(&self) -> bool {
        self.shortcut_ready.load(Ordering::Relaxed)
    }

    /// Whether a settle may have something to send (false: it would send nothing).
    #[inline]
    pub fn settle_wanted(&self) -> bool {
        self.settle_wanted.load(Ordering::Relaxed)
    }

    pub fn scope(&self) -> MutexGuard<'_, PassScope> {
        self.scope.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// A locked [`CommandState`]; on release it notes whether a settle has anything to send.
#[derive(Debug)]
pub struct StateGuard<'a> {
    state: RecordingGuard<'a, CommandState>,
    settle_wanted: &'a AtomicBool,
    shortcut_ready: &'a AtomicBool,
}

impl std::ops::Deref for StateGuard<'_> {
    type Target = CommandState;
    fn deref(&self) -> &CommandState {
        &self.state
    }
}

impl std::ops::DerefMut for StateGuard<'_> {
    fn deref_mut(&mut self) -> &mut CommandState {
        &mut self.state
    }
}

impl Drop for StateGuard<'_> {
    #[inline]
    fn drop(&mut self) {
        self.settle_wanted
            .store(self.state.wants_settle(), Ordering::Relaxed);
        self.shortcut_ready
            .store(self.state.has_push_shortcut(), Ordering::Relaxed);
    }
}

static COMMAND_BUFFERS: LazyLock<Table<vk::CommandBuffer, Arc<CommandBufferEntry>>> =
    LazyLock::new(Table::new);

/// Bumped whenever a command buffer is forgotten, so thread-local caches never answer with a
/// freed command buffer whose handle was reused.
static GENERATION: AtomicU64 = AtomicU64::new(0);

type CacheSlot = Option<(vk::CommandBuffer, u64, Arc<CommandBufferEntry>)>;

thread_local! {
    static CACHE: RefCell<CacheSlot> = const { RefCell::new(None) };
}

/// Starts tracking command buffers allocated on `device` at `level`.
pub fn track_command_buffers(
    device: &Arc<DeviceState>,
    buffers: &[vk::CommandBuffer],
    level: vk::CommandBufferLevel,
    pool: vk::CommandPool,
) {
    let dispatchable = device.copies.pool_dispatches(pool);
    for &buffer in buffers {
        COMMAND_BUFFERS.insert(
            buffer,
            Arc::new(CommandBufferEntry {
                device: Arc::clone(device),
                secondary: level == vk::CommandBufferLevel::SECONDARY,
                state: RecordingLock::new(CommandState::new(device.reversing())),
                settle_wanted: AtomicBool::new(false),
                shortcut_ready: AtomicBool::new(false),
                scope: Mutex::new(PassScope::default()),
                dispatchable,
                copies: Default::default(),
            }),
        );
    }
    // A handle can come back for a new command buffer (even of another device, when an
    // application destroyed a device with live pools): no cache may keep the old entry.
    GENERATION.fetch_add(1, Ordering::Release);
}

/// Stops tracking command buffers (freed, or their pool destroyed).
pub fn forget_command_buffers(buffers: &[vk::CommandBuffer]) {
    for buffer in buffers {
        if let Some(entry) = COMMAND_BUFFERS.remove(buffer) {
            entry.copies().destroy(&entry.device);
        }
    }
    uncache(buffers);
    // After the removal, so that a racing lookup cannot cache a removed entry under the new
    // generation.
    GENERATION.fetch_add(1, Ordering::Release);
}

/// Stops tracking every command buffer of a device (at `vkDestroyDevice`, for applications
/// that leave pools alive).
pub fn forget_device_command_buffers(objects: &DeviceObjects) {
    let pools: Vec<_> = objects
        .pools
        .0
        .read()
        .unwrap_or_else(PoisonError::into_inner)
        .values()
        .cloned()
        .collect();
    for pool in pools {
        let buffers = pool.lock().unwrap_or_else(PoisonError::into_inner);
        forget_command_buffers(&buffers);
    }
}

/// How many command buffers revz tracks, over every device of the process.
#[cfg(test)]
pub fn tracked_command_buffers() -> usize {
    COMMAND_BUFFERS
        .0
        .read()
        .unwrap_or_else(PoisonError::into_inner)
        .len()
}

/// Caches `entry` for this thread, unless the cache is in use further up this thread's stack
/// (a hook that called down, and something below called back into revz): then the lookup
/// simply stays uncached, never a double borrow.
fn remember(
    cache: &RefCell<CacheSlot>,
    buffer: vk::CommandBuffer,
    generation: u64,
    entry: &Arc<CommandBufferEntry>,
) {
    if let Ok(mut slot) = cache.try_borrow_mut() {
        *slot = Some((buffer, generation, Arc::clone(entry)));
    }
}

/// Runs `f` with the entry of a command buffer, if revz tracks it, without taking a reference
/// count on a cache hit (the per-draw path). From a thread-local destructor that runs after the
/// cache's own (a Vulkan call made while the thread exits), the lookup goes to the table
/// uncached instead of panicking.
#[inline]
pub fn with_command_buffer<R>(
    buffer: vk::CommandBuffer,
    f: impl FnOnce(&CommandBufferEntry) -> R,
) -> Option<R> {
    let generation = GENERATION.load(Ordering::Acquire);
    let mut f = Some(f);
    let cached = CACHE.try_with(|cache| {
        if let Ok(slot) = cache.try_borrow() {
            if let Some((cached, cached_generation, entry)) = slot.as_ref() {
                if *cached == buffer && *cached_generation == generation {
                    let f = f.take().expect("called once");
                    return Some(f(entry));
                }
            }
        }
        let entry = COMMAND_BUFFERS.get(&buffer)?;
        remember(cache, buffer, generation, &entry);
        let f = f.take().expect("called once");
        Some(f(&entry))
    });
    match cached {
        Ok(result) => result,
        // The cache is gone (this thread is exiting): uncached.
        Err(_) => {
            let entry = COMMAND_BUFFERS.get(&buffer)?;
            f.take().map(|f| f(&entry))
        }
    }
}

/// The entry of a command buffer, if revz tracks it (uncached where the cache is gone, as in
/// [`with_command_buffer`]).
#[inline]
pub fn command_buffer(buffer: vk::CommandBuffer) -> Option<Arc<CommandBufferEntry>> {
    let generation = GENERATION.load(Ordering::Acquire);
    let cached = CACHE.try_with(|cache| {
        if let Ok(slot) = cache.try_borrow() {
            if let Some((cached, cached_generation, entry)) = slot.as_ref() {
                if *cached == buffer && *cached_generation == generation {
                    return Some(Arc::clone(entry));
                }
            }
        }
        let entry = COMMAND_BUFFERS.get(&buffer)?;
        remember(cache, buffer, generation, &entry);
        Some(entry)
    });
    cached.unwrap_or_else(|_| COMMAND_BUFFERS.get(&buffer))
}

/// Whether this thread's cache still exists (false in thread-local destructors that run after
/// its own).
#[cfg(test)]
pub(crate) fn thread_cache_alive() -> bool {
    CACHE.try_with(|_| ()).is_ok()
}

/// Empties this thread's cache if it holds one of `buffers`, so that a forgotten command
/// buffer (and the device state it refers to) is not kept alive by the thread that freed it.
/// Other threads' caches are stale from the generation bump on and are replaced at their next
/// lookup.
fn uncache(buffers: &[vk::CommandBuffer]) {
    let _ = CACHE.try_with(|cache| {
        if let Ok(mut slot) = cache.try_borrow_mut() {
            if slot
                .as_ref()
                .is_some_and(|(cached, _, _)| buffers.contains(cached))
            {
                *slot = None;
            }
        }
    });
}
