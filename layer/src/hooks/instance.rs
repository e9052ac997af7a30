//! Instance-level hooks: instance and device creation, and instance-level dispatch.

use std::ffi::c_char;
use std::path::Path;
use std::sync::Arc;

use ash::vk;

use super::extensions::{self, EXTENDED_DYNAMIC_STATE, GET_PHYSICAL_DEVICE_PROPERTIES2};
use crate::boundary::{guarded, EntryPoint};
use crate::config::{self, layer_settings, AppIdentity, Mode, Settings, Sources};
use crate::ffi;
use crate::objects::DeviceObjects;
use crate::policy::{
    self, extended_dynamic_state_allowed, instance_needs_properties2, CompareOpFacts,
    CompareOpSource, DevicePolicy, ResolveSupport,
};
use crate::state::{DeviceCommands, DeviceState, DispatchKey, InstanceState, DEVICES, INSTANCES};
use crate::{logging, LAYER_NAME, VERSION};

static GET_INSTANCE_PROC_ADDR: EntryPoint = EntryPoint::new("vkGetInstanceProcAddr");
static CREATE_INSTANCE: EntryPoint = EntryPoint::new("vkCreateInstance");
static DESTROY_INSTANCE: EntryPoint = EntryPoint::new("vkDestroyInstance");
static CREATE_DEVICE: EntryPoint = EntryPoint::new("vkCreateDevice");
static READ_CONFIG: EntryPoint = EntryPoint::new("reading the configuration");

/// `vkGetInstanceProcAddr`: revz's hooks first, the next layer for everything else.
///
/// # Safety
/// Called by the loader or the application with the arguments the Vulkan spec allows.
pub unsafe extern "system" fn get_instance_proc_addr(
    instance: vk::Instance,
    p_name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    guarded(
        &GET_INSTANCE_PROC_ADDR,
        || {
            // SAFETY: the spec requires a NUL-terminated name; null is tolerated.
            let name = unsafe { ffi::c_str(p_name) }?;
            if let Some(hook) =
                super::instance_command(name).or_else(|| super::device_command(name))
            {
                return Some(hook);
            }
            if instance == vk::Instance::null() {
                return None;
            }
            // SAFETY: a non-null instance passed to vkGetInstanceProcAddr is live.
            let state = INSTANCES.get(unsafe { DispatchKey::of(instance) })?;
            if crate::policy::hides_instance_command(name, state.added_properties2) {
                return None;
            }
            // SAFETY: calling down the chain with the caller's arguments.
            unsafe { (state.next_get_instance_proc_addr)(instance, p_name) }
        },
        || None,
    )
}

/// `vkCreateInstance`: takes revz's link out of the loader chain, creates the instance below,
/// and records its dispatch and configuration.
///
/// # Safety
/// Called by the loader with the arguments the loader-layer interface specifies.
pub unsafe extern "system" fn create_instance(
    p_create_info: *const vk::InstanceCreateInfo,
    p_allocator: *const vk::AllocationCallbacks,
    p_instance: *mut vk::Instance,
) -> vk::Result {
    guarded(
        &CREATE_INSTANCE,
        || {
            // SAFETY: the loader passes a valid create info (null is tolerated).
            let Some(create_info) = (unsafe { p_create_info.as_ref() }) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the loader's create info carries its layer chain.
            let Some(link) = (unsafe { ffi::take_instance_link(create_info) }) else {
                log::error!("vkCreateInstance: no loader link info; was revz loaded as a layer?");
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            let (settings, setting_origins) = read_settings(create_info);
            let api_version = requested_api_version(create_info);
            // SAFETY: the application's extension names.
            let app_extensions = unsafe {
                extensions::names(
                    create_info.pp_enabled_extension_names,
                    create_info.enabled_extension_count,
                )
            };
            let app_properties2 = app_extensions.contains(&GET_PHYSICAL_DEVICE_PROPERTIES2);
            let added_properties2 =
                instance_needs_properties2(settings.mode, api_version, app_properties2);
            let properties2_enabled = added_properties2 || app_properties2;
            // The application's create info, or a copy with the instance extension added. The
            // loader's terminator passes each driver only the extensions it supports.
            let names_down = if added_properties2 {
                // SAFETY: the application's extension names.
                unsafe {
                    extensions::with_added(
                        create_info.pp_enabled_extension_names,
                        create_info.enabled_extension_count,
                        GET_PHYSICAL_DEVICE_PROPERTIES2,
                    )
                }
            } else {
                Vec::new()
            };
            let mut with_properties2 = *create_info;
            if added_properties2 {
                with_properties2.enabled_extension_count = names_down.len() as u32;
                with_properties2.pp_enabled_extension_names = names_down.as_ptr();
            }
            let p_create_info = if added_properties2 {
                &with_properties2
            } else {
                p_create_info
            };
            let gipa = link.get_instance_proc_addr;
            // SAFETY: querying a global command from the next layer.
            let Some(next_create) =
                (unsafe { gipa(vk::Instance::null(), c"vkCreateInstance".as_ptr()) })
            else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's vkCreateInstance has this signature.
            let next_create: vk::PFN_vkCreateInstance = unsafe { std::mem::transmute(next_create) };
            // SAFETY: calling down with the application's arguments (plus, where revz needs
            // it, one extension).
            let result = unsafe { next_create(p_create_info, p_allocator, p_instance) };
            if result != vk::Result::SUCCESS {
                return result;
            }
            // SAFETY: on success the next layer wrote a live instance.
            let instance = unsafe { *p_instance };
            if added_properties2 {
                log::info!(
                    "instance {instance:?}: enabled VK_KHR_get_physical_device_properties2 for \
                     this Vulkan 1.0 application (VK_EXT_extended_dynamic_state requires it)"
                );
            }
            // SAFETY: loading the next layer's instance commands for this instance.
            let next = unsafe {
                ash::Instance::load_with(
                    |name| std::mem::transmute(gipa(instance, name.as_ptr())),
                    instance,
                )
            };
            // SAFETY: `instance` is live.
            let key = unsafe { DispatchKey::of(instance) };
            INSTANCES.insert(
                key,
                InstanceState {
                    handle: instance,
                    api_version,
                    properties2_enabled,
                    added_properties2,
                    next_get_instance_proc_addr: gipa,
                    next,
                    settings,
                    application: application_json(create_info, api_version),
                    setting_origins,
                },
            );
            result
        },
        || vk::Result::ERROR_INITIALIZATION_FAILED,
    )
}

/// The application, as its depth profile names it.
fn application_json(create_info: &vk::InstanceCreateInfo, api_version: u32) -> serde_json::Value {
    let identity = app_identity(create_info);
    serde_json::json!({
        "executable": identity.executable,
        "application_name": identity.application_name,
        "engine_name": identity.engine_name,
        "api_version": format!(
            "{}.{}",
            vk::api_version_major(api_version),
            vk::api_version_minor(api_version)
        ),
    })
}

/// The API version the application asked for ([`policy::requested_api_version`]: 1.0 when
/// it gave none).
fn requested_api_version(create_info: &vk::InstanceCreateInfo) -> u32 {
    // SAFETY: `pApplicationInfo` is null or valid.
    let info = unsafe { create_info.p_application_info.as_ref() };
    policy::requested_api_version(info.map_or(0, |i| i.api_version))
}

/// What a device allows of depth/stencil resolves (`VkPhysicalDeviceDepthStencilResolveProperties`,
/// Vulkan 1.2): its depth modes, and whether depth and stencil modes may differ
/// (`independentResolveNone`, `independentResolve`). [`ResolveSupport::MINIMAL`] when it cannot
/// be asked. revz swaps MIN and MAX only where the device allows the swapped resolve.
///
/// # Safety
/// `physical_device` must be a live physical device of `instance`.
unsafe fn resolve_support(
    instance: &InstanceState,
    physical_device: vk::PhysicalDevice,
    api: u32,
) -> ResolveSupport {
    if !ResolveSupport::queried(api) {
        return ResolveSupport::MINIMAL;
    }
    // SAFETY: querying the next layer for a core 1.1 instance command.
    let found = unsafe {
        (instance.next_get_instance_proc_addr)(
            instance.handle,
            c"vkGetPhysicalDeviceProperties2".as_ptr(),
        )
    };
    let Some(found) = found else {
        return ResolveSupport::MINIMAL;
    };
    // SAFETY: the command has this type.
    let get: vk::PFN_vkGetPhysicalDeviceProperties2 = unsafe { std::mem::transmute(found) };
    let mut resolve = vk::PhysicalDeviceDepthStencilResolveProperties::default();
    let mut properties = vk::PhysicalDeviceProperties2 {
        p_next: (&mut resolve as *mut vk::PhysicalDeviceDepthStencilResolveProperties<'_>).cast(),
        ..Default::default()
    };
    // SAFETY: a live physical device and a valid output chain (core 1.2 structure).
    unsafe { get(physical_device, &mut properties) };
    ResolveSupport::reported(
        resolve.supported_depth_resolve_modes,
        resolve.independent_resolve_none == vk::TRUE,
        resolve.independent_resolve == vk::TRUE,
    )
}

/// The physical device's API version (1.0 if the next layer cannot say). Looked up by name
/// rather than through `ash`'s table, whose stand-in for a missing command aborts.
///
/// # Safety
/// `physical_device` must be a live physical device of `instance`.
unsafe fn device_api_version(instance: &InstanceState, physical_device: vk::PhysicalDevice) -> u32 {
    // SAFETY: the caller's contract.
    unsafe { device_properties(instance, physical_device) }.api_version
}

/// The physical device's properties through the next layer (defaults where it has no
/// `vkGetPhysicalDeviceProperties`).
///
/// # Safety
/// `physical_device` is a live physical device of `instance`.
unsafe fn device_properties(
    instance: &InstanceState,
    physical_device: vk::PhysicalDevice,
) -> vk::PhysicalDeviceProperties {
    // SAFETY: querying the next layer for an instance command.
    let found = unsafe {
        (instance.next_get_instance_proc_addr)(
            instance.handle,
            c"vkGetPhysicalDeviceProperties".as_ptr(),
        )
    };
    let mut properties = vk::PhysicalDeviceProperties {
        api_version: vk::API_VERSION_1_0,
        ..Default::default()
    };
    let Some(found) = found else {
        return properties;
    };
    // SAFETY: the command has this type.
    let get: vk::PFN_vkGetPhysicalDeviceProperties = unsafe { std::mem::transmute(found) };
    // SAFETY: a live physical device and a valid output.
    unsafe { get(physical_device, &mut properties) };
    properties
}

/// What converting depth copies needs of a physical device: its memory types and queue
/// families, asked of the next layer (a chain without these commands gets no memory types
/// and no compute families: copies then go down unconverted).
///
/// # Safety
/// `physical_device` is a live physical device of `instance`.
unsafe fn device_copies(
    instance: &InstanceState,
    physical_device: vk::PhysicalDevice,
    limits: &vk::PhysicalDeviceLimits,
) -> crate::depth_copy::DeviceCopies {
    let find = |name: &std::ffi::CStr| {
        // SAFETY: querying the next layer for an instance command.
        unsafe { (instance.next_get_instance_proc_addr)(instance.handle, name.as_ptr()) }
    };
    let mut memory = vk::PhysicalDeviceMemoryProperties::default();
    if let Some(found) = find(c"vkGetPhysicalDeviceMemoryProperties") {
        // SAFETY: the command has this type.
        let get: vk::PFN_vkGetPhysicalDeviceMemoryProperties =
            unsafe { std::mem::transmute(found) };
        // SAFETY: a live physical device and a valid output.
        unsafe { get(physical_device, &mut memory) };
    }
    let mut families = Vec::new();
    if let Some(found) = find(c"vkGetPhysicalDeviceQueueFamilyProperties") {
        // SAFETY: the command has this type.
        let get: vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties =
            unsafe { std::mem::transmute(found) };
        let mut count = 0;
        // SAFETY: the two-call idiom with valid outputs.
        unsafe { get(physical_device, &mut count, std::ptr::null_mut()) };
        families.resize(count as usize, vk::QueueFamilyProperties::default());
        // SAFETY: as above.
        unsafe { get(physical_device, &mut count, families.as_mut_ptr()) };
        families.truncate(count as usize);
    }
    crate::depth_copy::DeviceCopies::new(memory, &families, limits.max_storage_buffer_range)
}

/// Gathers the facts of [`CompareOpSource::decide`] for a device being created.
///
/// # Safety
/// `physical_device` must be a live physical device of `instance`.
unsafe fn compare_op_source(
    instance: &InstanceState,
    physical_device: vk::PhysicalDevice,
    create_info: &vk::DeviceCreateInfo,
    api: u32,
) -> CompareOpSource {
    let (extension, feature_struct, feature) = extended_dynamic_state_requested(create_info);
    let facts = CompareOpFacts {
        api,
        application_extension: extension && feature,
        application_feature_struct: feature_struct,
        mode_off: instance.settings.mode == Mode::Off,
        extension_allowed: extended_dynamic_state_allowed(api, instance.properties2_enabled),
        // Asked only where it decides (it queries the layers below).
        // SAFETY: the caller's contract.
        device_has_extension: &|| unsafe {
            device_has_extension(instance, physical_device, EXTENDED_DYNAMIC_STATE)
        },
    };
    CompareOpSource::decide(&facts)
}

/// Whether a device extension is offered, asked of the layers below.
///
/// # Safety
/// `physical_device` must be a live physical device of `instance`.
unsafe fn device_has_extension(
    instance: &InstanceState,
    physical_device: vk::PhysicalDevice,
    wanted: &std::ffi::CStr,
) -> bool {
    // SAFETY: querying the next layer for an instance command.
    let found = unsafe {
        (instance.next_get_instance_proc_addr)(
            instance.handle,
            c"vkEnumerateDeviceExtensionProperties".as_ptr(),
        )
    };
    let Some(found) = found else { return false };
    // SAFETY: the command has this type.
    let enumerate: vk::PFN_vkEnumerateDeviceExtensionProperties =
        unsafe { std::mem::transmute(found) };
    let mut count = 0;
    // SAFETY: the count query.
    let result = unsafe {
        enumerate(
            physical_device,
            std::ptr::null(),
            &mut count,
            std::ptr::null_mut(),
        )
    };
    if result != vk::Result::SUCCESS {
        return false;
    }
    let mut properties = vec![vk::ExtensionProperties::default(); count as usize];
    // SAFETY: room for `count` properties.
    let result = unsafe {
        enumerate(
            physical_device,
            std::ptr::null(),
            &mut count,
            properties.as_mut_ptr(),
        )
    };
    if result != vk::Result::SUCCESS && result != vk::Result::INCOMPLETE {
        return false;
    }
    properties
        .iter()
        .take(count as usize)
        .any(|p| p.extension_name_as_c_str() == Ok(wanted))
}

/// Whether the application enables `VK_EXT_extended_dynamic_state`, chains its feature
/// structure, and turns the feature on.
fn extended_dynamic_state_requested(create_info: &vk::DeviceCreateInfo) -> (bool, bool, bool) {
    // SAFETY: `enabledExtensionCount` NUL-terminated names.
    let names = unsafe {
        extensions::names(
            create_info.pp_enabled_extension_names,
            create_info.enabled_extension_count,
        )
    };
    let extension = names.contains(&EXTENDED_DYNAMIC_STATE);
    // SAFETY: a valid pNext chain (the application's contract).
    let features = unsafe {
        crate::chain::find::<vk::PhysicalDeviceExtendedDynamicStateFeaturesEXT<'_>>(
            create_info.p_next,
        )
    };
    let feature = features.is_some_and(|f| f.extended_dynamic_state == vk::TRUE);
    (extension, features.is_some(), feature)
}

/// What identifies this process to per-application config sections.
fn app_identity(create_info: &vk::InstanceCreateInfo) -> AppIdentity {
    let executable = std::env::current_exe()
        .ok()
        .and_then(|path| Some(path.file_name()?.to_string_lossy().into_owned()));
    // SAFETY: `pApplicationInfo` is null or valid, and its names null or NUL-terminated.
    let info = unsafe { create_info.p_application_info.as_ref() };
    // SAFETY: as above.
    let name = |ptr| unsafe { ffi::c_str(ptr) }.map(|name| name.to_string_lossy().into_owned());
    AppIdentity {
        executable,
        application_name: info.and_then(|i| name(i.p_application_name)),
        engine_name: info.and_then(|i| name(i.p_engine_name)),
    }
}

/// Resolves this instance's settings, installs the logger (first instance only), and logs the
/// warnings and the load line. Any failure here degrades to `off`.
/// The instance's settings, and where each got its value (`config::Resolved::origins`).
fn read_settings(
    create_info: &vk::InstanceCreateInfo,
) -> (Arc<Settings>, Vec<(crate::config::Key, String)>) {
    let settings = guarded(
        &READ_CONFIG,
        || {
            let env = |name: &str| std::env::var(name).ok();
            let read_file = |path: &Path| config::file::read(path);
            let is_dir = |path: &Path| path.is_dir();
            let resolved = config::resolve(&Sources {
                env: &env,
                read_file: &read_file,
                is_dir: &is_dir,
                app: app_identity(create_info),
                // SAFETY: the application's chain is valid per the spec.
                layer_settings: unsafe { layer_settings::read(create_info.p_next) },
            });
            let settings = resolved.settings;
            let log_problem = logging::init(
                settings.log_level,
                settings.log_file.as_deref(),
                settings.report.is_some(),
            );
            for warning in resolved.warnings.iter().chain(&log_problem) {
                log::warn!("{warning}");
            }
            let mode = settings.mode;
            let sources = if resolved.notes.is_empty() {
                String::new()
            } else {
                format!("; from {}", resolved.notes.join(", "))
            };
            log::info!(
                "revz {VERSION} loaded as {LAYER_NAME}: mode {mode}; {}{sources}",
                settings.summary()
            );
            (settings, resolved.origins)
        },
        || {
            let off = Settings {
                mode: Mode::Off,
                ..Settings::default()
            };
            (off, Vec::new())
        },
    );
    (Arc::new(settings.0), settings.1)
}

/// `vkDestroyInstance`.
///
/// # Safety
/// Called by the application with the arguments the Vulkan spec allows.
pub unsafe extern "system" fn destroy_instance(
    instance: vk::Instance,
    p_allocator: *const vk::AllocationCallbacks,
) {
    guarded(
        &DESTROY_INSTANCE,
        || {
            if instance == vk::Instance::null() {
                return;
            }
            // SAFETY: a non-null instance being destroyed is still live.
            let key = unsafe { DispatchKey::of(instance) };
            match INSTANCES.remove(key) {
                // SAFETY: calling down with the application's arguments.
                Some(state) => unsafe {
                    (state.next.fp_v1_0().destroy_instance)(instance, p_allocator)
                },
                None => log::error!(
                    "vkDestroyInstance: unknown instance {instance:?}; cannot pass it down"
                ),
            }
        },
        || (),
    )
}

/// `vkCreateDevice`: takes revz's link out of the loader chain, creates the device below, and
/// records its dispatch.
///
/// # Safety
/// Called by the loader with the arguments the loader-layer interface specifies.
pub unsafe extern "system" fn create_device(
    physical_device: vk::PhysicalDevice,
    p_create_info: *const vk::DeviceCreateInfo,
    p_allocator: *const vk::AllocationCallbacks,
    p_device: *mut vk::Device,
) -> vk::Result {
    guarded(
        &CREATE_DEVICE,
        || {
            // SAFETY: the loader passes a valid create info (null is tolerated).
            let Some(create_info) = (unsafe { p_create_info.as_ref() }) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // A physical device shares its instance's dispatch key; fall back to the only
            // instance if a loader ever breaks that.
            // SAFETY: `physical_device` is live.
            let instance = INSTANCES
                .get(unsafe { DispatchKey::of(physical_device) })
                .or_else(|| INSTANCES.sole());
            let Some(instance) = instance else {
                log::error!("vkCreateDevice: the physical device's instance is unknown");
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the loader's create info carries its layer chain.
            let Some(link) = (unsafe { ffi::take_device_link(create_info) }) else {
                log::error!("vkCreateDevice: no loader link info; was revz loaded as a layer?");
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            let gipa = link.get_instance_proc_addr;
            // SAFETY: querying an instance command from the next layer.
            let Some(next_create) = (unsafe { gipa(instance.handle, c"vkCreateDevice".as_ptr()) })
            else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's vkCreateDevice has this signature.
            let next_create: vk::PFN_vkCreateDevice = unsafe { std::mem::transmute(next_create) };
            let api = policy::device_api_version(
                instance.api_version,
                // SAFETY: a live physical device of this instance.
                unsafe { device_api_version(&instance, physical_device) },
            );
            // SAFETY: a live physical device of this instance; the application's create info.
            let source = unsafe { compare_op_source(&instance, physical_device, create_info, api) };
            // SAFETY: a live physical device of this instance.
            let resolve_support = unsafe { resolve_support(&instance, physical_device, api) };
            // Enabling VK_EXT_extended_dynamic_state for the application when revz needs it:
            // the application's extensions plus one, and the feature chained in front.
            let added_extended_dynamic_state = source == CompareOpSource::AddedExtension;
            let names_down = if added_extended_dynamic_state {
                // SAFETY: `enabledExtensionCount` names.
                unsafe {
                    extensions::with_added(
                        create_info.pp_enabled_extension_names,
                        create_info.enabled_extension_count,
                        EXTENDED_DYNAMIC_STATE,
                    )
                }
            } else {
                Vec::new()
            };
            // Multisampled read twins are written per sample by a storage image: the feature
            // is enabled where the device has it and revz would use it.
            let multisampled_twins = if instance.settings.mode != Mode::Off
                && instance.settings.reverse_observable == crate::config::Observable::Copies
            {
                // SAFETY: a live physical device of this instance.
                unsafe { multisampled_twin_samples(&instance, physical_device) }
            } else {
                vk::SampleCountFlags::empty()
            };
            // SAFETY: the application's create info.
            let app_features = unsafe { enabled_core_features(create_info) };
            let enable_storage_multisample = !multisampled_twins.is_empty()
                && app_features.shader_storage_image_multisample == vk::FALSE;
            let mut features_down = vk::PhysicalDeviceFeatures {
                shader_storage_image_multisample: vk::TRUE,
                ..app_features
            };
            let mut chain_down = crate::chain::Spliced::of(create_info.p_next);
            let mut with_features = *create_info;
            let mut multisampled_twins = multisampled_twins;
            if enable_storage_multisample {
                if create_info.p_enabled_features.is_null() {
                    // SAFETY: the application's valid pNext chain, alive until the call.
                    let spliced = unsafe {
                        chain_down.edit(|f: &vk::PhysicalDeviceFeatures2<'_>| {
                            Some(vk::PhysicalDeviceFeatures2 {
                                features: features_down,
                                ..*f
                            })
                        })
                    };
                    // SAFETY: as above.
                    let has_features2 = unsafe {
                        crate::chain::find::<vk::PhysicalDeviceFeatures2<'_>>(create_info.p_next)
                    }
                    .is_some();
                    if spliced.is_err() {
                        // An unknown structure before the features: enable nothing.
                        multisampled_twins = vk::SampleCountFlags::empty();
                    } else if !has_features2 {
                        features_down = vk::PhysicalDeviceFeatures {
                            shader_storage_image_multisample: vk::TRUE,
                            ..vk::PhysicalDeviceFeatures::default()
                        };
                        with_features.p_enabled_features = &features_down;
                    }
                } else {
                    with_features.p_enabled_features = &features_down;
                }
                with_features.p_next = chain_down.head();
            }
            let mut features = vk::PhysicalDeviceExtendedDynamicStateFeaturesEXT::default();
            let mut with_extension = with_features;
            if added_extended_dynamic_state {
                features.extended_dynamic_state = vk::TRUE;
                features.p_next = with_features.p_next.cast_mut();
                with_extension.p_next =
                    (&features as *const vk::PhysicalDeviceExtendedDynamicStateFeaturesEXT).cast();
                with_extension.enabled_extension_count = names_down.len() as u32;
                with_extension.pp_enabled_extension_names = names_down.as_ptr();
            }
            let p_create_info = if added_extended_dynamic_state || enable_storage_multisample {
                &with_extension
            } else {
                p_create_info
            };
            // SAFETY: calling down with the application's arguments (plus, where revz needs
            // it, one extension and its feature).
            let result =
                unsafe { next_create(physical_device, p_create_info, p_allocator, p_device) };
            if result != vk::Result::SUCCESS {
                return result;
            }
            // SAFETY: on success the next layer wrote a live device.
            let device = unsafe { *p_device };
            let gdpa = link.get_device_proc_addr;
            // SAFETY: loading the next layer's device commands for this device.
            let next = unsafe {
                ash::Device::load_with(
                    |name| std::mem::transmute(gdpa(device, name.as_ptr())),
                    device,
                )
            };
            // SAFETY: the next layer's GDPA and a live device.
            let commands = unsafe { DeviceCommands::load(gdpa, device, api) };
            let dynamic_compare_op = source.is_dynamic(commands.set_depth_compare_op.is_some());
            // SAFETY: a live physical device of this instance.
            let limits = unsafe { device_properties(&instance, physical_device) }.limits;
            // SAFETY: the application's extension names.
            let enabled_extensions = unsafe {
                extensions::names(
                    create_info.pp_enabled_extension_names,
                    create_info.enabled_extension_count,
                )
            };
            let depth_range_unrestricted =
                enabled_extensions.contains(&extensions::DEPTH_RANGE_UNRESTRICTED);
            let descriptor_heap = enabled_extensions.contains(&extensions::DESCRIPTOR_HEAP);
            // SAFETY: the application's create info (its features, or a valid pNext chain).
            let core_features = unsafe { enabled_core_features(create_info) };
            // SAFETY: a valid pNext chain (the application's contract).
            let mesh_shader = unsafe {
                crate::chain::find::<vk::PhysicalDeviceMeshShaderFeaturesEXT<'_>>(
                    create_info.p_next,
                )
            }
            .is_some_and(|features| features.mesh_shader == vk::TRUE);
            let policy = DevicePolicy::new(&instance.settings, dynamic_compare_op)
                .with_push_constant_space(limits.max_push_constants_size)
                .with_depth_range_unrestricted(depth_range_unrestricted)
                .with_descriptor_heap(descriptor_heap)
                .with_shader_stages(
                    core_features.geometry_shader == vk::TRUE,
                    core_features.tessellation_shader == vk::TRUE,
                    mesh_shader,
                )
                .with_multisampled_twins(multisampled_twins);
            if depth_range_unrestricted && instance.settings.mode == Mode::Infinite {
                log::info!(
                    "device {device:?}: the application enabled VK_EXT_depth_range_unrestricted: \
                     infinite mode reverses depth as complementary mode does here (its n / w \
                     cannot follow clears, viewports and clamps beyond the far plane)"
                );
            }
            if descriptor_heap && instance.settings.mode != Mode::Off {
                log::info!(
                    "device {device:?}: the application enabled VK_EXT_descriptor_heap, whose \
                     descriptors revz does not follow: depth images that shaders read or copies \
                     reach keep standard depth and their format; only depth attachments no \
                     shader or copy reaches are reversed"
                );
            }
            if enable_storage_multisample && !multisampled_twins.is_empty() {
                log::info!(
                    "device {device:?}: enabled shaderStorageImageMultisample for the read \
                     twins of multisampled depth images"
                );
            }
            match source {
                _ if !source.logged(instance.settings.mode == Mode::Off) => {}
                CompareOpSource::AddedExtension => log::info!(
                    "device {device:?}: enabled VK_EXT_extended_dynamic_state to make the depth \
                     compare op dynamic"
                ),
                CompareOpSource::Unavailable => log::info!(
                    "device {device:?}: the device offers neither Vulkan 1.3 to this \
                     application nor VK_EXT_extended_dynamic_state: draws into reversed \
                     attachments get their compare op from pipeline variants"
                ),
                _ => {}
            }
            log::debug!(
                "device {device:?} created, mode {}, depth path {}",
                instance.settings.mode,
                if policy.is_active() {
                    "active"
                } else {
                    "inactive"
                }
            );
            // SAFETY: a live physical device of this instance.
            let copies = unsafe { device_copies(&instance, physical_device, &limits) };
            // SAFETY: `device` is live.
            let key = unsafe { DispatchKey::of(device) };
            let objects = DeviceObjects::default();
            let profile = instance.settings.report.as_deref().map(|report| {
                objects
                    .keep_demotions
                    .store(true, std::sync::atomic::Ordering::Relaxed);
                let profile = crate::profile::Profile::new(
                    report,
                    instance.application.clone(),
                    &instance.settings,
                    &instance.setting_origins,
                );
                log::info!("depth profile: {}", profile.path().display());
                Arc::new(profile)
            });
            DEVICES.insert(
                key,
                DeviceState {
                    handle: device,
                    next_get_device_proc_addr: gdpa,
                    next,
                    commands,
                    settings: Arc::clone(&instance.settings),
                    policy,
                    resolve_support,
                    added_extended_dynamic_state,
                    observed: Default::default(),
                    cameras: Default::default(),
                    objects,
                    image_formats: crate::state::ImageFormatQuery {
                        physical_device,
                        get: instance
                            .next
                            .fp_v1_0()
                            .get_physical_device_image_format_properties,
                    },
                    profile,
                    copies,
                },
            );
            result
        },
        || vk::Result::ERROR_INITIALIZATION_FAILED,
    )
}

/// The sample counts of multisampled depth images whose read twin the device can write per
/// sample: it has `shaderStorageImageMultisample`, and `R32_SFLOAT` 2D optimal images of
/// storage and sampled usage with those counts (more than one sample).
///
/// # Safety
/// `physical_device` is a live physical device of `instance`.
unsafe fn multisampled_twin_samples(
    instance: &InstanceState,
    physical_device: vk::PhysicalDevice,
) -> vk::SampleCountFlags {
    let v = instance.next.fp_v1_0();
    let mut features = vk::PhysicalDeviceFeatures::default();
    // SAFETY: the caller's contract; valid output.
    unsafe { (v.get_physical_device_features)(physical_device, &mut features) };
    if features.shader_storage_image_multisample == vk::FALSE {
        return vk::SampleCountFlags::empty();
    }
    let mut properties = vk::ImageFormatProperties::default();
    // SAFETY: as above.
    let result = unsafe {
        (v.get_physical_device_image_format_properties)(
            physical_device,
            crate::depth_copy::twin::MULTISAMPLED_FORMAT,
            vk::ImageType::TYPE_2D,
            vk::ImageTiling::OPTIMAL,
            vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::STORAGE,
            vk::ImageCreateFlags::empty(),
            &mut properties,
        )
    };
    if result != vk::Result::SUCCESS {
        return vk::SampleCountFlags::empty();
    }
    properties.sample_counts & !vk::SampleCountFlags::TYPE_1
}

/// The core features the application enabled: `pEnabledFeatures`, or the
/// `VkPhysicalDeviceFeatures2` in its chain (the spec allows one or the other); none when
/// neither is given.
///
/// # Safety
/// `info` is the application's valid create info.
unsafe fn enabled_core_features(info: &vk::DeviceCreateInfo<'_>) -> vk::PhysicalDeviceFeatures {
    // SAFETY: null or valid (the caller's contract).
    if let Some(features) = unsafe { info.p_enabled_features.as_ref() } {
        return *features;
    }
    // SAFETY: a valid pNext chain (the caller's contract).
    unsafe { crate::chain::find::<vk::PhysicalDeviceFeatures2<'_>>(info.p_next) }
        .map_or_else(vk::PhysicalDeviceFeatures::default, |f| f.features)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn create_instance_without_a_loader_chain_fails_cleanly() {
        let info = vk::InstanceCreateInfo::default();
        let mut instance = vk::Instance::null();
        // SAFETY: valid pointers; the chain simply lacks the loader's link info.
        let result = unsafe { create_instance(&info, std::ptr::null(), &mut instance) };
        assert_eq!(result, vk::Result::ERROR_INITIALIZATION_FAILED);
        assert_eq!(instance, vk::Instance::null());
        // SAFETY: null create info is tolerated.
        let result = unsafe { create_instance(std::ptr::null(), std::ptr::null(), &mut instance) };
        assert_eq!(result, vk::Result::ERROR_INITIALIZATION_FAILED);
    }

    #[test]
    fn get_instance_proc_addr_tolerates_nulls() {
        // SAFETY: null name and null instance are tolerated.
        unsafe {
            assert!(get_instance_proc_addr(vk::Instance::null(), std::ptr::null()).is_none());
            assert!(get_instance_proc_addr(vk::Instance::null(), c"vkCmdDraw".as_ptr()).is_none());
            assert!(
                get_instance_proc_addr(vk::Instance::null(), c"vkCreateInstance".as_ptr())
                    .is_some()
            );
        }
    }

    #[test]
    fn destroying_a_null_instance_is_a_no_op() {
        // SAFETY: null is allowed by the spec.
        unsafe { destroy_instance(vk::Instance::null(), std::ptr::null()) };
    }
}
