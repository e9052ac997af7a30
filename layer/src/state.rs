//! Per-instance and per-device layer state, keyed by the loader's dispatch pointer.
//!
//! The first pointer-sized word of every dispatchable handle is the loader's dispatch table, so
//! an instance and its physical devices share a key, and a device, its queues and its command
//! buffers share another. A lookup clones an `Arc` and releases the registry lock before the
//! caller calls down the chain; the lock is only taken at object creation and destruction and
//! for lookups on paths that are not per-draw.

use std::collections::HashMap;
use std::sync::{Arc, LazyLock, Mutex, MutexGuard, PoisonError};

use ash::vk::{self, Handle};

use crate::config::Settings;

/// The loader's dispatch table pointer of a dispatchable handle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DispatchKey(usize);

impl DispatchKey {
    /// Reads the key of `handle`.
    ///
    /// # Safety
    /// `handle` must be a live dispatchable Vulkan handle created through the loader.
    pub unsafe fn of<H: Handle>(handle: H) -> DispatchKey {
        // SAFETY: dispatchable handles point at an object whose first word is the loader's
        // dispatch table pointer (loader-layer interface, "Dispatchable Object Creation").
        DispatchKey(unsafe { *(handle.as_raw() as *const usize) })
    }
}

/// What the layer keeps for one `VkInstance`.
pub struct InstanceState {
    pub handle: vk::Instance,
    /// The next layer's `vkGetInstanceProcAddr`, for everything revz does not intercept.
    pub next_get_instance_proc_addr: vk::PFN_vkGetInstanceProcAddr,
    /// The next layer's instance commands.
    pub next: ash::Instance,
    pub settings: Arc<Settings>,
}

impl std::fmt::Debug for InstanceState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("InstanceState")
            .field("handle", &self.handle)
            .field("settings", &self.settings)
            .finish_non_exhaustive()
    }
}

/// What the layer keeps for one `VkDevice`.
pub struct DeviceState {
    pub handle: vk::Device,
    /// The next layer's `vkGetDeviceProcAddr`, for everything revz does not intercept.
    pub next_get_device_proc_addr: vk::PFN_vkGetDeviceProcAddr,
    /// The next layer's device commands.
    pub next: ash::Device,
    pub settings: Arc<Settings>,
}

impl std::fmt::Debug for DeviceState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DeviceState")
            .field("handle", &self.handle)
            .field("settings", &self.settings)
            .finish_non_exhaustive()
    }
}

/// A map from dispatch key to shared state.
#[derive(Debug)]
pub struct Registry<T> {
    map: LazyLock<Mutex<HashMap<DispatchKey, Arc<T>>>>,
}

impl<T> Registry<T> {
    /// An empty registry, usable in a `static`.
    pub const fn new() -> Self {
        Registry {
            map: LazyLock::new(|| Mutex::new(HashMap::new())),
        }
    }

    fn lock(&self) -> MutexGuard<'_, HashMap<DispatchKey, Arc<T>>> {
        // A panic while the lock was held (caught at the boundary) leaves a consistent map:
        // every operation on it is a single insert, remove or clone.
        self.map.lock().unwrap_or_else(PoisonError::into_inner)
    }

    pub fn insert(&self, key: DispatchKey, state: T) {
        self.lock().insert(key, Arc::new(state));
    }

    pub fn get(&self, key: DispatchKey) -> Option<Arc<T>> {
        self.lock().get(&key).cloned()
    }

    pub fn remove(&self, key: DispatchKey) -> Option<Arc<T>> {
        self.lock().remove(&key)
    }

    /// The only entry, if there is exactly one.
    pub fn sole(&self) -> Option<Arc<T>> {
        let map = self.lock();
        let mut values = map.values();
        match (values.next(), values.next()) {
            (Some(only), None) => Some(Arc::clone(only)),
            _ => None,
        }
    }
}

impl<T> Default for Registry<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// Every live instance the layer has seen created.
pub static INSTANCES: Registry<InstanceState> = Registry::new();
/// Every live device the layer has seen created.
pub static DEVICES: Registry<DeviceState> = Registry::new();
