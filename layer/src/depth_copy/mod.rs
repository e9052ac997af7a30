//! Copies of reversed depth images hand the application standard values (issue #21).
//!
//! A copy whose one end is a reversed depth image and whose other end is a buffer or an image
//! of standard depth (which way, and whether at all: `crate::policy::CopyFacts::decide`) goes
//! through revz's scratch buffer in the same command buffer:
//!
//! 1. the texels are copied into the scratch buffer, tightly packed, behind a 32-byte header
//!    written with `vkCmdUpdateBuffer`;
//! 2. a compute dispatch (`shaders/depth_convert.comp.spvasm`) maps them in place: d -> 1 - d
//!    (a bit complement on UNORM integers, so D16 and D24 are exact), or infinite mode's
//!    affine map with the device's n / f ([`plan::DepthMap`]);
//! 3. they are copied to where the application asked, with its row pitch, never touching
//!    the padding between its rows.
//!
//! Steps 1 and 3 are transfers, like the application's own copy: its barriers before and
//! after the copy cover them unchanged. revz's barriers order 1 -> 2 -> 3 on the scratch
//! buffer only. The dispatch binds revz's compute pipeline and descriptor set; the
//! application's compute pipeline and descriptor sets are bound again after it
//! ([`scratch::ComputeBindings`]). Push constants are not used, so none are disturbed.
//!
//! What this module owns: the per-device conversion pipeline ([`DeviceCopies`]), the scratch
//! buffers of each command buffer ([`scratch`], released when the command buffer is begun
//! again, freed or its pool destroyed), the arithmetic of a conversion ([`plan`]: pure, unit
//! tested) and the recording of the sequence ([`record`]). The copy hooks themselves are in
//! `crate::hooks::command::transfers`.

pub mod compute_bindings;
pub mod plan;
pub mod record;
pub mod scratch;
pub mod twin;

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::{Arc, OnceLock};

use ash::vk;

use crate::policy::Unconverted;

/// The conversion shader, assembled from `shaders/depth_convert.comp.spvasm` (a test checks
/// they agree).
pub const SHADER: &[u8] = include_bytes!("depth_convert.spv");

/// The per-sample conversion of multisampled read twins (`depth_convert_ms.comp`, compiled
/// with glslang; a test checks it is current).
pub const MS_SHADER: &[u8] = include_bytes!("depth_convert_ms.comp.spv");

/// What a device needs to convert copies: its memory types and compute-capable queue
/// families (read at `vkCreateDevice`), and the conversion pipeline (created at the first
/// conversion).
pub struct DeviceCopies {
    memory: vk::PhysicalDeviceMemoryProperties,
    /// Bit i: queue family i supports graphics and compute (families past 63 count as not).
    compute_families: u64,
    max_storage_buffer_range: u32,
    /// Queue family of every live command pool.
    pool_families: crate::objects::Table<vk::CommandPool, u32>,
    /// Push-descriptor update templates of the compute bind point: pushing with one disturbs
    /// what revz would have to bind again.
    compute_push_templates: crate::objects::Table<
        vk::DescriptorUpdateTemplate,
        Arc<[vk::DescriptorUpdateTemplateEntry]>,
    >,
    pipeline: OnceLock<Option<ConvertPipeline>>,
    /// The pipeline of each [`plan::Specialization`], created at its first conversion
    /// (`None`: the device refused it).
    specialized: [OnceLock<Option<vk::Pipeline>>; plan::Specialization::COUNT],
    /// The refresh pipeline of multisampled read twins, created at its first refresh.
    multisampled: OnceLock<Option<MultisampledConvert>>,
    /// One bit per [`Unconverted`] reason already logged.
    warned: AtomicU8,
}

impl std::fmt::Debug for DeviceCopies {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DeviceCopies")
            .field("compute_families", &self.compute_families)
            .finish_non_exhaustive()
    }
}

/// The refresh of multisampled read twins (`depth_convert_ms.comp`): set 0 is the copy
/// conversion's (the scratch buffer, whose first 16 bytes hold the map), set 1 the image's
/// depth (a sampled image) and its twin (a storage image).
#[derive(Clone, Copy, Debug)]
pub struct MultisampledConvert {
    pub set_layout: vk::DescriptorSetLayout,
    pub layout: vk::PipelineLayout,
    pub module: vk::ShaderModule,
    pub pipeline: vk::Pipeline,
}

/// revz's compute pipeline layout and shader module, shared by the specialized pipelines.
#[derive(Clone, Copy, Debug)]
pub struct ConvertPipeline {
    pub set_layout: vk::DescriptorSetLayout,
    pub layout: vk::PipelineLayout,
    pub module: vk::ShaderModule,
}

impl DeviceCopies {
    pub fn new(
        memory: vk::PhysicalDeviceMemoryProperties,
        families: &[vk::QueueFamilyProperties],
        max_storage_buffer_range: u32,
    ) -> DeviceCopies {
        let compute_families = families
            .iter()
            .take(64)
            .enumerate()
            // A dispatch needs compute; a copy into a depth aspect needs graphics.
            .filter(|(_, family)| {
                family
                    .queue_flags
                    .contains(vk::QueueFlags::COMPUTE | vk::QueueFlags::GRAPHICS)
            })
            .fold(0u64, |bits, (i, _)| bits | 1 << i);
        DeviceCopies {
            memory,
            compute_families,
            max_storage_buffer_range,
            pool_families: Default::default(),
            compute_push_templates: Default::default(),
            pipeline: OnceLock::new(),
            specialized: std::array::from_fn(|_| OnceLock::new()),
            multisampled: OnceLock::new(),
            warned: AtomicU8::new(0),
        }
    }

    /// A command pool was created for `family`; command buffers of a protected pool never
    /// dispatch (revz's scratch memory is not protected).
    pub fn note_pool(&self, pool: vk::CommandPool, family: u32, protected: bool) {
        self.pool_families
            .insert(pool, if protected { u32::MAX } else { family });
    }

    pub fn forget_pool(&self, pool: vk::CommandPool) {
        self.pool_families.remove(&pool);
    }

    /// A descriptor update template was created; only compute push-descriptor ones matter
    /// (`compute_push`: their entries, which a push with one is read through, to be pushed
    /// again after a conversion's dispatch).
    pub fn note_template(
        &self,
        template: vk::DescriptorUpdateTemplate,
        compute_push: Option<&[vk::DescriptorUpdateTemplateEntry]>,
    ) {
        if let Some(entries) = compute_push {
            self.compute_push_templates.insert(template, entries.into());
        }
    }

    pub fn forget_template(&self, template: vk::DescriptorUpdateTemplate) {
        self.compute_push_templates.remove(&template);
    }

    /// The entries of `template` where pushing descriptors with it binds compute descriptors.
    pub fn compute_push_entries(
        &self,
        template: vk::DescriptorUpdateTemplate,
    ) -> Option<Arc<[vk::DescriptorUpdateTemplateEntry]>> {
        self.compute_push_templates.get(&template)
    }

    /// Whether command buffers of `pool` can record a dispatch (unknown pools: no).
    pub fn pool_dispatches(&self, pool: vk::CommandPool) -> bool {
        self.pool_families
            .get(&pool)
            .is_some_and(|family| family < 64 && self.compute_families & (1 << family) != 0)
    }

    /// Whether a conversion of `size` scratch bytes fits one storage buffer descriptor.
    pub fn fits(&self, size: u64) -> bool {
        size <= u64::from(self.max_storage_buffer_range)
    }

    /// A memory type for revz's scratch buffers among `allowed`: device-local if one is.
    pub fn memory_type(&self, allowed: u32) -> Option<u32> {
        let count = (self.memory.memory_type_count as usize).min(vk::MAX_MEMORY_TYPES);
        let types = &self.memory.memory_types[..count];
        let allowed = |i: usize| allowed & (1 << i) != 0;
        let find = |wanted: vk::MemoryPropertyFlags| {
            (0..types.len())
                .find(|&i| allowed(i) && types[i].property_flags.contains(wanted))
                .map(|i| i as u32)
        };
        find(vk::MemoryPropertyFlags::DEVICE_LOCAL)
            .or_else(|| find(vk::MemoryPropertyFlags::empty()))
    }

    /// The conversion layouts and module, created on first use (`None` if the device refused
    /// them: logged once, and copies then go down unconverted).
    pub fn layouts(&self, device: vk::Device, next: &ash::Device) -> Option<ConvertPipeline> {
        *self.pipeline.get_or_init(|| {
            // SAFETY: a live device; revz's own objects.
            let created = unsafe { create_layouts(device, next) };
            if let Err(result) = created {
                log::error!(
                    "cannot create revz's depth conversion pipeline layout ({result:?}): copies \
                     of reversed depth images keep reversed values"
                );
            }
            created.ok()
        })
    }

    /// The layouts and the pipeline of `specialization`, each created on first use (`None` as
    /// for [`Self::layouts`], logged once per pipeline).
    pub fn pipeline(
        &self,
        device: vk::Device,
        next: &ash::Device,
        specialization: plan::Specialization,
    ) -> Option<(ConvertPipeline, vk::Pipeline)> {
        let layouts = self.layouts(device, next)?;
        let pipeline = self.specialized[specialization.index()].get_or_init(|| {
            // SAFETY: a live device; revz's own layouts and module.
            let created = unsafe { create_pipeline(device, next, &layouts, specialization) };
            if let Err(result) = created {
                log::error!(
                    "cannot create revz's depth conversion pipeline for {specialization:?} \
                     ({result:?}): such copies keep the values they had"
                );
            }
            created.ok()
        });
        pipeline.map(|pipeline| (layouts, pipeline))
    }

    /// The refresh pipeline of multisampled twins, created on first use (`None` if the device
    /// refused it: logged once, and such twins are then not refreshed).
    pub fn multisampled(
        &self,
        device: vk::Device,
        next: &ash::Device,
    ) -> Option<MultisampledConvert> {
        let layouts = self.layouts(device, next)?;
        *self.multisampled.get_or_init(|| {
            // SAFETY: a live device; revz's own layouts.
            let created = unsafe { create_multisampled(device, next, &layouts) };
            if let Err(result) = created {
                log::error!(
                    "cannot create revz's refresh pipeline of multisampled read twins \
                     ({result:?}): shaders reading them read what they last held"
                );
            }
            created.ok()
        })
    }

    /// Logs once per reason that copies go down unconverted.
    pub fn warn_unconverted(&self, why: Unconverted) {
        let bit = 1u8 << (why as u8);
        if self.warned.fetch_or(bit, Ordering::Relaxed) & bit == 0 {
            log::warn!(
                "a copy of a reversed depth image is not converted ({why}): the application \
                 gets or writes reversed depth values there"
            );
        }
    }

    /// Destroys the pipelines (at `vkDestroyDevice`; the device is idle).
    pub fn destroy(&self, device: vk::Device, next: &ash::Device) {
        let v = next.fp_v1_0();
        for pipeline in self
            .specialized
            .iter()
            .filter_map(|p| p.get().copied().flatten())
        {
            // SAFETY: revz's own pipeline, no longer used.
            unsafe { (v.destroy_pipeline)(device, pipeline, std::ptr::null()) };
        }
        if let Some(Some(m)) = self.multisampled.get() {
            // SAFETY: revz's own objects, no longer used.
            unsafe {
                (v.destroy_pipeline)(device, m.pipeline, std::ptr::null());
                (v.destroy_shader_module)(device, m.module, std::ptr::null());
                (v.destroy_pipeline_layout)(device, m.layout, std::ptr::null());
                (v.destroy_descriptor_set_layout)(device, m.set_layout, std::ptr::null());
            }
        }
        if let Some(Some(p)) = self.pipeline.get() {
            // SAFETY: revz's own objects, no longer used.
            unsafe {
                (v.destroy_shader_module)(device, p.module, std::ptr::null());
                (v.destroy_pipeline_layout)(device, p.layout, std::ptr::null());
                (v.destroy_descriptor_set_layout)(device, p.set_layout, std::ptr::null());
            }
        }
    }
}

/// Creates the conversion layouts and module: one storage buffer at set 0, binding 0, no push
/// constants. Whatever was created is destroyed on failure.
///
/// # Safety
/// `device` must be live and `next` its next layer's table.
unsafe fn create_layouts(
    device: vk::Device,
    next: &ash::Device,
) -> Result<ConvertPipeline, vk::Result> {
    let v = next.fp_v1_0();
    let null = std::ptr::null();
    let binding = [vk::DescriptorSetLayoutBinding::default()
        .binding(0)
        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
        .descriptor_count(1)
        .stage_flags(vk::ShaderStageFlags::COMPUTE)];
    let set_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&binding);
    let mut set_layout = vk::DescriptorSetLayout::null();
    // SAFETY: valid create infos and outputs (here and below).
    unsafe { (v.create_descriptor_set_layout)(device, &set_info, null, &mut set_layout) }
        .result()?;
    let set_layouts = [set_layout];
    let layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
    let mut layout = vk::PipelineLayout::null();
    let mut module = vk::ShaderModule::null();
    let result = (|| {
        // SAFETY: as above.
        unsafe { (v.create_pipeline_layout)(device, &layout_info, null, &mut layout) }.result()?;
        let words = ash::util::read_spv(&mut std::io::Cursor::new(SHADER))
            .map_err(|_| vk::Result::ERROR_INITIALIZATION_FAILED)?;
        let module_info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: as above; the module is valid SPIR-V 1.0 (tested).
        unsafe { (v.create_shader_module)(device, &module_info, null, &mut module) }.result()
    })();
    match result {
        Ok(()) => Ok(ConvertPipeline {
            set_layout,
            layout,
            module,
        }),
        Err(error) => {
            // SAFETY: revz's own objects (null handles are ignored).
            unsafe {
                (v.destroy_shader_module)(device, module, null);
                (v.destroy_pipeline_layout)(device, layout, null);
                (v.destroy_descriptor_set_layout)(device, set_layout, null);
            }
            Err(error)
        }
    }
}

/// Creates the refresh pipeline of multisampled twins over the copy conversion's set layout.
/// Whatever was created is destroyed on failure.
///
/// # Safety
/// `device` must be live, `next` its next layer's table, and `base` created on it.
unsafe fn create_multisampled(
    device: vk::Device,
    next: &ash::Device,
    base: &ConvertPipeline,
) -> Result<MultisampledConvert, vk::Result> {
    let v = next.fp_v1_0();
    let null = std::ptr::null();
    let bindings = [
        vk::DescriptorSetLayoutBinding::default()
            .binding(0)
            .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::COMPUTE),
        vk::DescriptorSetLayoutBinding::default()
            .binding(1)
            .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::COMPUTE),
    ];
    let set_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
    let mut made = MultisampledConvert {
        set_layout: vk::DescriptorSetLayout::null(),
        layout: vk::PipelineLayout::null(),
        module: vk::ShaderModule::null(),
        pipeline: vk::Pipeline::null(),
    };
    let result = (|| {
        // SAFETY: valid create infos and outputs (here and below).
        unsafe { (v.create_descriptor_set_layout)(device, &set_info, null, &mut made.set_layout) }
            .result()?;
        let set_layouts = [base.set_layout, made.set_layout];
        let layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        // SAFETY: as above.
        unsafe { (v.create_pipeline_layout)(device, &layout_info, null, &mut made.layout) }
            .result()?;
        let words = ash::util::read_spv(&mut std::io::Cursor::new(MS_SHADER))
            .map_err(|_| vk::Result::ERROR_INITIALIZATION_FAILED)?;
        let module_info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: as above; the module is valid SPIR-V 1.0 (tested).
        unsafe { (v.create_shader_module)(device, &module_info, null, &mut made.module) }
            .result()?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(made.module)
            .name(c"main");
        let info = vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(made.layout);
        // SAFETY: as above.
        unsafe {
            (v.create_compute_pipelines)(
                device,
                vk::PipelineCache::null(),
                1,
                &info,
                null,
                &mut made.pipeline,
            )
        }
        .result()
    })();
    match result {
        Ok(()) => Ok(made),
        Err(error) => {
            // SAFETY: revz's own objects (null handles are ignored).
            unsafe {
                (v.destroy_pipeline)(device, made.pipeline, null);
                (v.destroy_shader_module)(device, made.module, null);
                (v.destroy_pipeline_layout)(device, made.layout, null);
                (v.destroy_descriptor_set_layout)(device, made.set_layout, null);
            }
            Err(error)
        }
    }
}

/// Creates the conversion pipeline of `specialization` (its three constants).
///
/// # Safety
/// `device` must be live, `next` its next layer's table, and `layouts` created on it.
unsafe fn create_pipeline(
    device: vk::Device,
    next: &ash::Device,
    layouts: &ConvertPipeline,
    specialization: plan::Specialization,
) -> Result<vk::Pipeline, vk::Result> {
    let v = next.fp_v1_0();
    let constants = specialization.constants();
    let entries: [vk::SpecializationMapEntry; 4] =
        std::array::from_fn(|i| vk::SpecializationMapEntry {
            constant_id: i as u32,
            offset: (i * 4) as u32,
            size: 4,
        });
    let data: Vec<u8> = constants.iter().flat_map(|c| c.to_ne_bytes()).collect();
    let specialization_info = vk::SpecializationInfo::default()
        .map_entries(&entries)
        .data(&data);
    let stage = vk::PipelineShaderStageCreateInfo::default()
        .stage(vk::ShaderStageFlags::COMPUTE)
        .module(layouts.module)
        .name(c"main")
        .specialization_info(&specialization_info);
    let info = vk::ComputePipelineCreateInfo::default()
        .stage(stage)
        .layout(layouts.layout);
    let mut pipeline = vk::Pipeline::null();
    // SAFETY: valid create info (the constants are 32-bit, as the shader declares them: a
    // bool constant reads a VkBool32) and output.
    unsafe {
        (v.create_compute_pipelines)(
            device,
            vk::PipelineCache::null(),
            1,
            &info,
            std::ptr::null(),
            &mut pipeline,
        )
    }
    .result()?;
    Ok(pipeline)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ash::vk::Handle;

    /// The embedded binary is the assembly source, assembled for Vulkan 1.0, and valid there.
    /// `REVZ_BLESS=1` rewrites the binary from the source.
    #[test]
    fn the_embedded_shader_is_its_source_assembled_for_vulkan_1_0() {
        use spirv_tools::assembler::{self, Assembler};
        use spirv_tools::val::{self, Validator};
        use spirv_tools::TargetEnv;
        let source = include_str!("../../../shaders/depth_convert.comp.spvasm");
        let words = assembler::create(Some(TargetEnv::Vulkan_1_0))
            .assemble(source, assembler::AssemblerOptions::default())
            .unwrap_or_else(|e| panic!("assembly: {e}"))
            .as_words()
            .to_vec();
        val::create(Some(TargetEnv::Vulkan_1_0))
            .validate(&words, None)
            .unwrap_or_else(|e| panic!("the conversion shader does not validate: {e}"));
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        if std::env::var_os("REVZ_BLESS").is_some() {
            let path = concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/src/depth_copy/depth_convert.spv"
            );
            std::fs::write(path, &bytes).unwrap();
        }
        assert!(
            bytes == SHADER,
            "layer/src/depth_copy/depth_convert.spv is stale: run \
             REVZ_BLESS=1 cargo test -p revz-layer the_embedded_shader"
        );
    }

    /// The embedded refresh shader of multisampled twins is its GLSL source compiled by
    /// glslang (where `glslangValidator` is installed: `cargo xtask setup`), and valid for
    /// Vulkan 1.0.
    #[test]
    fn the_embedded_multisampled_shader_is_its_source_compiled() {
        use spirv_tools::val::{self, Validator};
        use spirv_tools::TargetEnv;
        let words = ash::util::read_spv(&mut std::io::Cursor::new(MS_SHADER)).unwrap();
        val::create(Some(TargetEnv::Vulkan_1_0))
            .validate(&words, None)
            .unwrap_or_else(|e| panic!("the multisampled refresh shader does not validate: {e}"));
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/src/depth_copy");
        let out = std::env::temp_dir().join(format!("revz-ms-{}.spv", std::process::id()));
        let run = std::process::Command::new("glslangValidator")
            .args(["-V", "--target-env", "vulkan1.0", "-o"])
            .arg(&out)
            .arg(format!("{dir}/depth_convert_ms.comp"))
            .output();
        let Ok(run) = run else {
            eprintln!("glslangValidator is not installed: cannot recompile the shader");
            return;
        };
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stdout)
        );
        let compiled = std::fs::read(&out).unwrap();
        std::fs::remove_file(&out).ok();
        assert!(
            compiled == MS_SHADER,
            "layer/src/depth_copy/depth_convert_ms.comp.spv is stale: recompile it (the command \
             in depth_convert_ms.comp)"
        );
    }

    #[test]
    fn compute_families_and_memory_types_are_chosen_from_the_device() {
        let families = [
            vk::QueueFamilyProperties {
                queue_flags: vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE,
                ..Default::default()
            },
            vk::QueueFamilyProperties {
                queue_flags: vk::QueueFlags::TRANSFER,
                ..Default::default()
            },
        ];
        let mut memory = vk::PhysicalDeviceMemoryProperties {
            memory_type_count: 2,
            ..Default::default()
        };
        memory.memory_types[0].property_flags = vk::MemoryPropertyFlags::HOST_VISIBLE;
        memory.memory_types[1].property_flags = vk::MemoryPropertyFlags::DEVICE_LOCAL;
        let copies = DeviceCopies::new(memory, &families, 1 << 27);
        let (graphics, transfer) = (vk::CommandPool::from_raw(1), vk::CommandPool::from_raw(2));
        copies.note_pool(graphics, 0, false);
        copies.note_pool(transfer, 1, false);
        let protected = vk::CommandPool::from_raw(4);
        copies.note_pool(protected, 0, true);
        assert!(copies.pool_dispatches(graphics));
        assert!(!copies.pool_dispatches(transfer));
        assert!(!copies.pool_dispatches(protected));
        assert!(!copies.pool_dispatches(vk::CommandPool::from_raw(3)));
        assert_eq!(copies.memory_type(0b11), Some(1));
        assert_eq!(copies.memory_type(0b01), Some(0));
        assert_eq!(copies.memory_type(0), None);
        assert!(copies.fits(1 << 27) && !copies.fits((1 << 27) + 1));
    }
}
