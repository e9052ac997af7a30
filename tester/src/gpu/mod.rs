//! Vulkan bring-up and teardown: the loader entry, the instance (optionally with the Khronos
//! validation layer and a `VK_EXT_debug_utils` messenger that counts what it reports), physical
//! device selection, the logical device (with the optional features a scene needs and the
//! device has, and `VK_EXT_depth_clip_control` or `VK_EXT_graphics_pipeline_library` when a
//! scene asks for it) and its graphics queue, the memory-type helper and host-visible buffers.
//!
//! Files: this one holds the types; `instance.rs` the loader, instance, messenger and device
//! listing; `device.rs` feature selection and the logical device ([`Gpu::new`]).
//!
//! Everything created here is destroyed by `Drop`, in reverse order of creation, so that the
//! validation layer has nothing to report as leaked at `vkDestroyDevice` / `vkDestroyInstance`.

use std::ffi::{c_void, CStr};
use std::fmt;
use std::io::Write as _;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

use anyhow::{anyhow, bail, Context, Result};
use ash::vk;

use crate::target::ResolveSupport;

/// The Khronos validation layer, enabled through `ppEnabledLayerNames` by `--validation`.
pub const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Counts the validation messages that make a run fail, shared with the debug messenger
/// callback through its `pUserData`.
#[derive(Debug, Default)]
pub struct ValidationLog {
    counted: AtomicU32,
}

impl ValidationLog {
    /// Number of counted messages so far: every ERROR, and every WARNING of type VALIDATION or
    /// PERFORMANCE.
    pub fn count(&self) -> u32 {
        self.counted.load(Ordering::SeqCst)
    }
}

/// The debug-utils callback: counts ERROR messages (any type) and WARNING messages of type
/// VALIDATION or PERFORMANCE, printing each counted one to stderr; everything else is ignored.
unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    let counted = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        Some("ERROR")
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING)
        && types.intersects(
            vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
    {
        Some("WARNING")
    } else {
        None
    };
    let Some(severity_name) = counted else {
        return vk::FALSE;
    };
    if !user_data.is_null() {
        // SAFETY: `user_data` is `Arc::as_ptr` of the `ValidationLog` that `InstanceCtx` keeps
        // alive until after the instance (and with it every messenger) is destroyed.
        let log = unsafe { &*(user_data as *const ValidationLog) };
        log.counted.fetch_add(1, Ordering::SeqCst);
    }
    // SAFETY: the implementation passes a valid callback-data structure (or null) for the
    // duration of the call; its strings are null or NUL-terminated.
    let (id_name, message) = unsafe {
        match data.as_ref() {
            Some(data) => (
                data.message_id_name_as_c_str()
                    .map_or_else(|| "(no id)".into(), CStr::to_string_lossy),
                data.message_as_c_str()
                    .map_or_else(|| "(no message)".into(), CStr::to_string_lossy),
            ),
            None => ("(no id)".into(), "(no message)".into()),
        }
    };
    // Never panic inside a callback called from C: ignore a failed write to stderr.
    let _ = writeln!(
        std::io::stderr(),
        "validation: {severity_name} {id_name}: {message}"
    );
    vk::FALSE
}

/// What the tester prints and records about the physical device it renders on.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    /// `VkPhysicalDeviceProperties::deviceName`.
    pub name: String,
    /// `VkPhysicalDeviceDriverProperties::driverName` ("unknown" before Vulkan 1.2).
    pub driver_name: String,
    /// `VkPhysicalDeviceDriverProperties::driverInfo`.
    pub driver_info: String,
    /// `VkPhysicalDeviceProperties::apiVersion`.
    pub api_version: u32,
}

impl DeviceInfo {
    /// `<driverName> <driverInfo>`.
    pub fn driver(&self) -> String {
        if self.driver_info.is_empty() {
            self.driver_name.clone()
        } else {
            format!("{} {}", self.driver_name, self.driver_info)
        }
    }

    /// The device's Vulkan version as `major.minor.patch`.
    pub fn api_version_string(&self) -> String {
        let v = self.api_version;
        format!(
            "{}.{}.{}",
            vk::api_version_major(v),
            vk::api_version_minor(v),
            vk::api_version_patch(v)
        )
    }
}

/// How to bring the GPU up.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Case-insensitive substring of the device name; `None` prefers lavapipe ("llvmpipe").
    pub device: Option<String>,
    /// Enable `VK_LAYER_KHRONOS_validation` and count its messages.
    pub validation: bool,
    /// With `validation`: enable its synchronization validation too
    /// (`VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT`).
    pub sync_validation: bool,
    /// Optional features to enable where the device has them.
    pub features: Features,
    /// The highest Vulkan version to ask for (default: 1.3 where the loader has it, else 1.2).
    /// Below 1.1 the tester enables `VK_KHR_get_physical_device_properties2` only where a
    /// requested feature needs it (`depthClipControl`, `graphicsPipelineLibrary`), as a
    /// Vulkan 1.0 application would.
    pub max_api_version: Option<u32>,
}

/// The optional device features the tester may enable (everything else stays off).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Features {
    /// `dynamicRendering`: Vulkan 1.3, or `VK_KHR_dynamic_rendering` below it (enabled with
    /// what it requires).
    pub dynamic_rendering: bool,
    /// `vkCmdSetDepthCompareOp`: Vulkan 1.3, or `VK_EXT_extended_dynamic_state`'s
    /// `extendedDynamicState` below it.
    pub dynamic_compare_op: bool,
    /// `vkCreateRenderPass2` with depth/stencil resolves: Vulkan 1.2, or
    /// `VK_KHR_create_renderpass2` and `VK_KHR_depth_stencil_resolve` below it (not a feature:
    /// not in [`Features::names`]).
    pub depth_stencil_resolve: bool,
    /// `separateDepthStencilLayouts` (Vulkan 1.2): barriers and layouts of one aspect of a
    /// depth/stencil image.
    pub separate_depth_stencil_layouts: bool,
    /// `depthBounds`.
    pub depth_bounds: bool,
    /// `depthBiasClamp`.
    pub depth_bias_clamp: bool,
    /// `VK_EXT_depth_clip_control`'s `depthClipControl` (the extension is enabled with it).
    pub depth_clip_control: bool,
    /// `VK_EXT_graphics_pipeline_library`'s `graphicsPipelineLibrary` (the extension and the
    /// `VK_KHR_pipeline_library` it requires are enabled with it).
    pub graphics_pipeline_library: bool,
    /// `VK_EXT_depth_range_unrestricted` (an extension without a feature): viewport depth
    /// ranges and clear values outside [0, 1].
    pub depth_range_unrestricted: bool,
    /// `depthClamp`.
    pub depth_clamp: bool,
    /// `VK_EXT_depth_clip_enable`'s `depthClipEnable` (the extension is enabled with it):
    /// pipelines that clamp depth and keep clipping it, as D3D translators make every one.
    pub depth_clip_enable: bool,
    /// `geometryShader`.
    pub geometry_shader: bool,
    /// `tessellationShader`.
    pub tessellation_shader: bool,
    /// `VK_KHR_push_descriptor` (an extension without a feature): `vkCmdPushDescriptorSetKHR`.
    pub push_descriptor: bool,
    /// `VK_EXT_shader_object`'s `shaderObject` (Vulkan 1.3 only: the tester enables it with
    /// `dynamicRendering`, which the extension requires): pipelines of the flat program bound
    /// as vertex and fragment shader objects with their state set dynamically
    /// ([`crate::plan::Program::ShaderObjects`]).
    pub shader_object: bool,
    /// `VK_EXT_mesh_shader`'s `meshShader` (Vulkan 1.3 only; no task shaders): pipelines of
    /// [`crate::plan::Program::Mesh`].
    pub mesh_shader: bool,
    /// `VK_EXT_descriptor_buffer`'s `descriptorBuffer` with `bufferDeviceAddress` (Vulkan 1.3
    /// only): the depth pyramid's compute descriptors in a descriptor buffer
    /// ([`crate::plan::TileDescriptors::Buffer`]), as vkd3d-proton and Zink bind every
    /// descriptor where the driver has it.
    pub descriptor_buffer: bool,
    /// `VK_KHR_maintenance6`'s `maintenance6` (Vulkan 1.3 only): the bind commands taking an
    /// info (`vkCmdBindDescriptorSets2KHR`, `vkCmdSetDescriptorBufferOffsets2EXT`).
    pub maintenance6: bool,
    /// `VK_KHR_dynamic_rendering_local_read`'s `dynamicRenderingLocalRead` (Vulkan 1.3 only:
    /// the tester enables it with `dynamicRendering`, which the extension requires; core in
    /// 1.4, which the tester does not ask for): input attachments, by-region barriers and the
    /// `RENDERING_LOCAL_READ_KHR` layout inside `vkCmdBeginRendering`
    /// ([`crate::plan::PassKind::DynamicRenderingLocalRead`]).
    pub dynamic_rendering_local_read: bool,
    /// `multiview` (Vulkan 1.1, or `VK_KHR_multiview` below it, enabled with it): passes that
    /// render several views, one per array layer ([`crate::plan::PassSpec::view_mask`]).
    pub multiview: bool,
}

impl Features {
    /// The Vulkan names of the features that are set, for reports.
    pub fn names(self) -> Vec<&'static str> {
        [
            (self.dynamic_rendering, "dynamicRendering"),
            (self.dynamic_compare_op, "extendedDynamicState"),
            (
                self.separate_depth_stencil_layouts,
                "separateDepthStencilLayouts",
            ),
            (self.depth_bounds, "depthBounds"),
            (self.depth_bias_clamp, "depthBiasClamp"),
            (self.depth_clip_control, "depthClipControl"),
            (self.graphics_pipeline_library, "graphicsPipelineLibrary"),
            (
                self.depth_range_unrestricted,
                "VK_EXT_depth_range_unrestricted",
            ),
            (self.depth_clamp, "depthClamp"),
            (self.depth_clip_enable, "depthClipEnable"),
            (self.geometry_shader, "geometryShader"),
            (self.tessellation_shader, "tessellationShader"),
            (self.push_descriptor, "VK_KHR_push_descriptor"),
            (self.shader_object, "shaderObject"),
            (self.mesh_shader, "meshShader"),
            (self.descriptor_buffer, "descriptorBuffer"),
            (self.maintenance6, "maintenance6"),
            (
                self.dynamic_rendering_local_read,
                "dynamicRenderingLocalRead",
            ),
            (self.multiview, "multiview"),
        ]
        .into_iter()
        .filter_map(|(on, name)| on.then_some(name))
        .collect()
    }

    /// The features set in both.
    pub fn and(self, other: Features) -> Features {
        Features {
            dynamic_rendering: self.dynamic_rendering && other.dynamic_rendering,
            dynamic_compare_op: self.dynamic_compare_op && other.dynamic_compare_op,
            depth_stencil_resolve: self.depth_stencil_resolve && other.depth_stencil_resolve,
            separate_depth_stencil_layouts: self.separate_depth_stencil_layouts
                && other.separate_depth_stencil_layouts,
            depth_bounds: self.depth_bounds && other.depth_bounds,
            depth_bias_clamp: self.depth_bias_clamp && other.depth_bias_clamp,
            depth_clip_control: self.depth_clip_control && other.depth_clip_control,
            graphics_pipeline_library: self.graphics_pipeline_library
                && other.graphics_pipeline_library,
            depth_range_unrestricted: self.depth_range_unrestricted
                && other.depth_range_unrestricted,
            depth_clamp: self.depth_clamp && other.depth_clamp,
            depth_clip_enable: self.depth_clip_enable && other.depth_clip_enable,
            geometry_shader: self.geometry_shader && other.geometry_shader,
            tessellation_shader: self.tessellation_shader && other.tessellation_shader,
            push_descriptor: self.push_descriptor && other.push_descriptor,
            shader_object: self.shader_object && other.shader_object,
            mesh_shader: self.mesh_shader && other.mesh_shader,
            descriptor_buffer: self.descriptor_buffer && other.descriptor_buffer,
            maintenance6: self.maintenance6 && other.maintenance6,
            dynamic_rendering_local_read: self.dynamic_rendering_local_read
                && other.dynamic_rendering_local_read,
            multiview: self.multiview && other.multiview,
        }
    }
}

/// Loader entry, instance and (optional) debug messenger; destroyed after the device.
struct InstanceCtx {
    // `Drop` below destroys the messenger and the instance explicitly; `entry` (which keeps
    // libvulkan loaded) and `log` (the messengers' user data) are dropped only after that.
    entry: ash::Entry,
    instance: ash::Instance,
    api_version: u32,
    /// `VK_KHR_get_physical_device_properties2`, where the instance is below 1.1 and enabled
    /// it (the features and properties queries beyond Vulkan 1.0 go through it).
    properties2: Option<ash::khr::get_physical_device_properties2::Instance>,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    log: Arc<ValidationLog>,
    /// Why validation was asked for and left out ([`InstanceCtx::new`]'s `shader_object`).
    validation_skipped: Option<String>,
}

/// The instance, the chosen physical device, the logical device and its graphics queue.
pub struct Gpu {
    /// The logical device (only the optional features in `enabled`, and the extensions of
    /// `depthClipControl` and `graphicsPipelineLibrary` when they are among them).
    pub device: ash::Device,
    /// A queue of `queue_family` that supports graphics (and therefore transfer).
    pub queue: vk::Queue,
    /// The queue family index of `queue`.
    pub queue_family: u32,
    /// The chosen physical device.
    pub physical_device: vk::PhysicalDevice,
    /// What the tester reports about the device.
    pub info: DeviceInfo,
    /// The optional features the device has.
    pub supported: Features,
    /// The optional features enabled at device creation (requested and supported).
    pub enabled: Features,
    /// The extensions standing in for core commands below their version (see
    /// [`Gpu::cmd_begin_rendering`] and the methods after it).
    dynamic_rendering_khr: Option<ash::khr::dynamic_rendering::Device>,
    extended_dynamic_state: Option<ash::ext::extended_dynamic_state::Device>,
    create_renderpass2_khr: Option<ash::khr::create_renderpass2::Device>,
    push_descriptor_khr: Option<ash::khr::push_descriptor::Device>,
    /// `VK_EXT_shader_object`'s commands, where `enabled.shader_object`.
    pub shader_object: Option<ash::ext::shader_object::Device>,
    /// `VK_EXT_mesh_shader`'s commands, where `enabled.mesh_shader`.
    pub mesh_shader: Option<ash::ext::mesh_shader::Device>,
    /// `VK_EXT_descriptor_buffer`'s commands and properties, where `enabled.descriptor_buffer`.
    pub descriptor_buffer: Option<(
        ash::ext::descriptor_buffer::Device,
        vk::PhysicalDeviceDescriptorBufferPropertiesEXT<'static>,
    )>,
    /// `VK_KHR_maintenance6`'s commands, where `enabled.maintenance6`.
    pub maintenance6: Option<ash::khr::maintenance6::Device>,
    /// `VK_KHR_dynamic_rendering_local_read`'s commands, where
    /// `enabled.dynamic_rendering_local_read`.
    pub dynamic_rendering_local_read: Option<ash::khr::dynamic_rendering_local_read::Device>,
    memory_properties: vk::PhysicalDeviceMemoryProperties,
    // Dropped after `Drop::drop` has destroyed the device.
    instance: InstanceCtx,
}

impl fmt::Debug for Gpu {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Gpu")
            .field("device", &self.device.handle())
            .field("queue", &self.queue)
            .field("queue_family", &self.queue_family)
            .field("physical_device", &self.physical_device)
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        // SAFETY: the device is idle-waited before destruction; every object created from it
        // borrows `Gpu` and is therefore already dropped.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_device(None);
        }
    }
}

/// A buffer in host-visible, host-coherent memory, persistently mapped.
pub struct HostBuffer<'a> {
    device: &'a ash::Device,
    /// The buffer handle.
    pub buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    mapped: *mut u8,
    size: usize,
}

// SAFETY: `mapped` is owned by the buffer like a boxed byte slice: written only through
// `&mut self` (`write`) and read through `&self` (`contents`), so the usual borrow rules
// keep a writer from racing readers on other threads. The Vulkan handles are plain values;
// the memory stays mapped until `Drop`.
unsafe impl Send for HostBuffer<'_> {}
// SAFETY: as above: shared access only reads.
unsafe impl Sync for HostBuffer<'_> {}

impl fmt::Debug for HostBuffer<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("HostBuffer")
            .field("buffer", &self.buffer)
            .field("size", &self.size)
            .finish_non_exhaustive()
    }
}

impl Drop for HostBuffer<'_> {
    fn drop(&mut self) {
        // SAFETY: the handles are null or were created from `device`, which outlives `self`;
        // the GPU is done with them (every submission is fenced before resources drop).
        // Destroying null handles is a no-op; freeing memory unmaps it.
        unsafe {
            self.device.destroy_buffer(self.buffer, None);
            self.device.free_memory(self.memory, None);
        }
    }
}

impl<'a> HostBuffer<'a> {
    /// Creates a mapped host-visible coherent buffer of `size` bytes.
    pub fn new(gpu: &'a Gpu, size: usize, usage: vk::BufferUsageFlags) -> Result<Self> {
        let mut this = HostBuffer {
            device: &gpu.device,
            buffer: vk::Buffer::null(),
            memory: vk::DeviceMemory::null(),
            mapped: std::ptr::null_mut(),
            size,
        };
        let info = vk::BufferCreateInfo::default()
            .size(size as vk::DeviceSize)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        this.buffer = unsafe { gpu.device.create_buffer(&info, None) }
            .with_context(|| format!("vkCreateBuffer ({size} bytes, {usage:?}) failed"))?;
        // SAFETY: valid buffer.
        let requirements = unsafe { gpu.device.get_buffer_memory_requirements(this.buffer) };
        // A buffer whose address shaders or descriptors take needs memory with addresses.
        let flags = if usage.contains(vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS) {
            vk::MemoryAllocateFlags::DEVICE_ADDRESS
        } else {
            vk::MemoryAllocateFlags::empty()
        };
        this.memory = gpu.allocate_with(
            requirements,
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
            vk::MemoryPropertyFlags::empty(),
            flags,
        )?;
        // SAFETY: fresh buffer and memory of a compatible type and sufficient size.
        unsafe { gpu.device.bind_buffer_memory(this.buffer, this.memory, 0) }
            .context("vkBindBufferMemory failed")?;
        // SAFETY: host-visible memory, not mapped yet; mapped for the buffer's lifetime.
        let mapped = unsafe {
            gpu.device
                .map_memory(this.memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())
        }
        .context("vkMapMemory failed")?;
        this.mapped = mapped.cast();
        Ok(this)
    }

    /// Copies `bytes` to the start of the buffer (visible to the device at the next submit:
    /// the memory is coherent).
    pub fn write(&mut self, bytes: &[u8]) {
        assert!(
            bytes.len() <= self.size,
            "write past the end of a host buffer"
        );
        // SAFETY: `mapped` points to at least `size` mapped bytes; no GPU work uses the buffer
        // while the host writes (writes happen before the submit).
        unsafe { std::ptr::copy_nonoverlapping(bytes.as_ptr(), self.mapped, bytes.len()) };
    }

    /// The buffer's device address (a buffer made with `SHADER_DEVICE_ADDRESS` usage).
    pub fn address(&self) -> vk::DeviceAddress {
        let info = vk::BufferDeviceAddressInfo::default().buffer(self.buffer);
        // SAFETY: a live buffer of this device; the caller made it with the usage.
        unsafe { self.device.get_buffer_device_address(&info) }
    }

    /// The buffer's contents (coherent memory: valid once the writing submission's fence has
    /// signalled and a TRANSFER -> HOST barrier was recorded).
    pub fn contents(&self) -> &[u8] {
        // SAFETY: `mapped` points to `size` mapped bytes that live as long as `self`; callers
        // read only after the GPU work writing them has completed.
        unsafe { std::slice::from_raw_parts(self.mapped, self.size) }
    }
}

mod device;
mod instance;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feature_names_are_vulkan_names_of_the_set_features() {
        let all = Features {
            dynamic_rendering: true,
            dynamic_compare_op: true,
            depth_stencil_resolve: true,
            separate_depth_stencil_layouts: true,
            depth_bounds: true,
            depth_bias_clamp: true,
            depth_clip_control: true,
            graphics_pipeline_library: true,
            depth_range_unrestricted: true,
            depth_clamp: true,
            depth_clip_enable: true,
            geometry_shader: true,
            tessellation_shader: true,
            push_descriptor: true,
            shader_object: true,
            mesh_shader: true,
            descriptor_buffer: true,
            maintenance6: true,
            dynamic_rendering_local_read: true,
            multiview: true,
        };
        assert_eq!(
            all.names(),
            [
                "dynamicRendering",
                "extendedDynamicState",
                "separateDepthStencilLayouts",
                "depthBounds",
                "depthBiasClamp",
                "depthClipControl",
                "graphicsPipelineLibrary",
                "VK_EXT_depth_range_unrestricted",
                "depthClamp",
                "depthClipEnable",
                "geometryShader",
                "tessellationShader",
                "VK_KHR_push_descriptor",
                "shaderObject",
                "meshShader",
                "descriptorBuffer",
                "maintenance6",
                "dynamicRenderingLocalRead",
                "multiview"
            ]
        );
        let some = Features {
            depth_bias_clamp: true,
            ..Features::default()
        };
        assert_eq!(all.and(some), some);
        assert_eq!(some.names(), ["depthBiasClamp"]);
        assert!(Features::default().names().is_empty());
    }
}
