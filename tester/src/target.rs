//! The offscreen render target: the depth-format choice (`--depth-format`) and the two
//! attachments (an R8G8B8A8_UNORM color image and a depth image of the chosen format), each in
//! device-local memory with its image view, the color image usable as a transfer source for
//! read-back, the depth image too unless `--no-depth-readback` (and a transfer destination
//! only for scenes that clear it with `vkCmdClearDepthStencilImage`); plus, for shadow-map
//! scenes, a D32_SFLOAT shadow map with SAMPLED usage (never read back, never transferred),
//! and for multisampled scenes a transient multisampled color and depth attachment pair
//! (resolved into the two main images, never read back) with the resolve modes the device
//! supports for them, checked here.

use std::fmt;

use anyhow::{bail, Context, Result};
use ash::vk;
use clap::ValueEnum;

use crate::gpu::Gpu;
use crate::plan::{DepthSubresources, Multisample, ResolveMode};

/// The color attachment format.
pub const COLOR_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// The depth formats the tester can render with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, ValueEnum)]
pub enum DepthFormat {
    /// VK_FORMAT_D16_UNORM
    #[value(name = "d16")]
    D16,
    /// VK_FORMAT_X8_D24_UNORM_PACK32
    #[value(name = "x8-d24")]
    X8D24,
    /// VK_FORMAT_D24_UNORM_S8_UINT
    #[value(name = "d24-s8")]
    D24S8,
    /// VK_FORMAT_D32_SFLOAT
    #[value(name = "d32")]
    D32,
    /// VK_FORMAT_D32_SFLOAT_S8_UINT
    #[value(name = "d32-s8")]
    D32S8,
}

impl DepthFormat {
    /// The Vulkan format.
    pub fn vk_format(self) -> vk::Format {
        match self {
            DepthFormat::D16 => vk::Format::D16_UNORM,
            DepthFormat::X8D24 => vk::Format::X8_D24_UNORM_PACK32,
            DepthFormat::D24S8 => vk::Format::D24_UNORM_S8_UINT,
            DepthFormat::D32 => vk::Format::D32_SFLOAT,
            DepthFormat::D32S8 => vk::Format::D32_SFLOAT_S8_UINT,
        }
    }

    /// The Vulkan name of the format, without the `VK_FORMAT_` prefix (`D32_SFLOAT`).
    pub fn vk_name(self) -> &'static str {
        match self {
            DepthFormat::D16 => "D16_UNORM",
            DepthFormat::X8D24 => "X8_D24_UNORM_PACK32",
            DepthFormat::D24S8 => "D24_UNORM_S8_UINT",
            DepthFormat::D32 => "D32_SFLOAT",
            DepthFormat::D32S8 => "D32_SFLOAT_S8_UINT",
        }
    }

    /// Whether the format has a stencil aspect.
    pub fn has_stencil(self) -> bool {
        matches!(self, DepthFormat::D24S8 | DepthFormat::D32S8)
    }

    /// The aspects of the whole image: DEPTH, plus STENCIL for formats that have one (what
    /// layout transitions and the attachment view must name).
    pub fn aspects(self) -> vk::ImageAspectFlags {
        if self.has_stencil() {
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
        } else {
            vk::ImageAspectFlags::DEPTH
        }
    }

    /// Bytes per texel when only the DEPTH aspect is copied to a buffer: 2 for D16, 4 for the
    /// others (the 24-bit formats copy as 32-bit words with the depth in the low 24 bits).
    pub fn depth_copy_texel_size(self) -> usize {
        match self {
            DepthFormat::D16 => 2,
            DepthFormat::X8D24 | DepthFormat::D24S8 | DepthFormat::D32 | DepthFormat::D32S8 => 4,
        }
    }
}

impl fmt::Display for DepthFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.vk_name())
    }
}

/// Fails with a clear message unless `format` supports, with optimal tiling, everything in
/// `features`.
fn require_format(
    gpu: &Gpu,
    format: vk::Format,
    name: &str,
    features: vk::FormatFeatureFlags,
    role: &str,
) -> Result<()> {
    // SAFETY: valid physical device of this instance.
    let properties = unsafe {
        gpu.instance()
            .get_physical_device_format_properties(gpu.physical_device, format)
    };
    if !properties.optimal_tiling_features.contains(features) {
        bail!("device '{}' cannot use {name} as {role}", gpu.info.name);
    }
    Ok(())
}

/// Whether the device filters `format` linearly in optimal tiling (lavapipe 22.3 does not for
/// depth formats; most GPUs do).
pub fn filters_linearly(gpu: &Gpu, format: vk::Format) -> bool {
    // SAFETY: valid physical device of this instance.
    let properties = unsafe {
        gpu.instance()
            .get_physical_device_format_properties(gpu.physical_device, format)
    };
    properties
        .optimal_tiling_features
        .contains(vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR)
}

/// One device-local image with its memory and view.
pub struct Attachment<'a> {
    device: &'a ash::Device,
    /// The image.
    pub image: vk::Image,
    memory: vk::DeviceMemory,
    /// A view of all its aspects, of mip level 0 and array layer 0 (the whole image but for
    /// the main depth image of a plan with [`Target::DepthSlice`](crate::plan::Target) passes).
    pub view: vk::ImageView,
    /// A view of its depth aspect alone, which shaders sample ([`Self::add_depth_view`]; null
    /// until then): every mip level and array layer (a 2D-array view where it has several
    /// layers).
    pub depth_view: vk::ImageView,
    /// A view of its stencil aspect alone, where it has one and shaders sample it (null
    /// otherwise), of the same subresources.
    pub stencil_view: vk::ImageView,
    /// Where it has several mip levels or array layers: a view of all its aspects per level
    /// and layer (index `level * layers + layer`), each an attachment of its own
    /// ([`Self::slice_view`]); empty otherwise.
    slice_views: Vec<vk::ImageView>,
    /// A 2D-array view of all its aspects, of mip level 0 and every array layer: the
    /// attachment of a multiview pass, which renders view `i` into layer `i`
    /// ([`Self::add_array_view`]; null until then).
    pub array_view: vk::ImageView,
    /// Its mip levels and array layers.
    pub subresources: DepthSubresources,
    /// The image format.
    pub format: vk::Format,
    /// What it was created with (`render.json`'s `recorded`).
    pub usage: vk::ImageUsageFlags,
    pub samples: vk::SampleCountFlags,
    pub extent: vk::Extent2D,
}

impl fmt::Debug for Attachment<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Attachment")
            .field("image", &self.image)
            .field("view", &self.view)
            .field("format", &self.format)
            .finish_non_exhaustive()
    }
}

/// Device-local memory allocated for `image` and bound to it (the caller frees it).
fn bind_memory(gpu: &Gpu, image: vk::Image) -> Result<vk::DeviceMemory> {
    // SAFETY: a valid image of this device.
    let requirements = unsafe { gpu.device.get_image_memory_requirements(image) };
    let memory = gpu.allocate(
        requirements,
        vk::MemoryPropertyFlags::empty(),
        vk::MemoryPropertyFlags::DEVICE_LOCAL,
    )?;
    // SAFETY: fresh memory of a compatible type and sufficient size, an image not yet bound.
    if let Err(e) = unsafe { gpu.device.bind_image_memory(image, memory, 0) } {
        // SAFETY: the memory was allocated above and is bound to nothing.
        unsafe { gpu.device.free_memory(memory, None) };
        return Err(e).context("vkBindImageMemory failed");
    }
    Ok(memory)
}

/// An image with its memory bound and no view: the copy routes' 3D images
/// (`crate::readback`) and `revz-tester transfers`' images, 2D or 3D (by `extent.depth`),
/// optimal tiling, one level, layer and sample.
pub struct BoundImage<'a> {
    device: &'a ash::Device,
    pub image: vk::Image,
    memory: vk::DeviceMemory,
    pub extent: vk::Extent3D,
}

impl fmt::Debug for BoundImage<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("BoundImage")
            .field("image", &self.image)
            .field("extent", &self.extent)
            .finish_non_exhaustive()
    }
}

impl<'a> BoundImage<'a> {
    /// A 3D image where `extent` is deeper than 1, else 2D, of `format`, `usage` and `flags`;
    /// an error where the device has no such image.
    pub fn new(
        gpu: &'a Gpu,
        format: vk::Format,
        (usage, flags): (vk::ImageUsageFlags, vk::ImageCreateFlags),
        extent: vk::Extent3D,
    ) -> Result<Self> {
        let image_type = if extent.depth > 1 {
            vk::ImageType::TYPE_3D
        } else {
            vk::ImageType::TYPE_2D
        };
        // SAFETY: a physical device of this instance.
        let supported = unsafe {
            gpu.instance().get_physical_device_image_format_properties(
                gpu.physical_device,
                format,
                image_type,
                vk::ImageTiling::OPTIMAL,
                usage,
                flags,
            )
        };
        if supported.is_err() {
            anyhow::bail!("the device has no {image_type:?} images of {format:?} with {usage:?}");
        }
        let mut this = BoundImage {
            device: &gpu.device,
            image: vk::Image::null(),
            memory: vk::DeviceMemory::null(),
            extent,
        };
        let info = vk::ImageCreateInfo::default()
            .flags(flags)
            .image_type(image_type)
            .format(format)
            .extent(extent)
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device and create info.
        this.image = unsafe { gpu.device.create_image(&info, None) }
            .with_context(|| format!("vkCreateImage ({image_type:?}, {format:?}) failed"))?;
        this.memory = bind_memory(gpu, this.image)?;
        Ok(this)
    }

    /// Its texels.
    pub fn texels(&self) -> usize {
        (self.extent.width * self.extent.height * self.extent.depth) as usize
    }
}

impl Drop for BoundImage<'_> {
    fn drop(&mut self) {
        // SAFETY: handles of `device` (null or created by it), no GPU work pending.
        unsafe {
            self.device.destroy_image(self.image, None);
            self.device.free_memory(self.memory, None);
        }
    }
}

impl Drop for Attachment<'_> {
    fn drop(&mut self) {
        // SAFETY: the handles are null or were created from `device` (which outlives `self`),
        // and no GPU work using them is pending. Destroying null handles is a no-op.
        unsafe {
            self.device.destroy_image_view(self.view, None);
            self.device.destroy_image_view(self.depth_view, None);
            self.device.destroy_image_view(self.stencil_view, None);
            self.device.destroy_image_view(self.array_view, None);
            for &view in &self.slice_views {
                self.device.destroy_image_view(view, None);
            }
            self.device.destroy_image(self.image, None);
            self.device.free_memory(self.memory, None);
        }
    }
}

impl<'a> Attachment<'a> {
    /// Creates a 2D single-sample image of `format` with `usage`, its memory and a view of
    /// `aspects`.
    pub fn new(
        gpu: &'a Gpu,
        format: vk::Format,
        aspects: vk::ImageAspectFlags,
        usage: vk::ImageUsageFlags,
        extent: vk::Extent2D,
    ) -> Result<Self> {
        Self::with_samples(
            gpu,
            format,
            aspects,
            usage,
            extent,
            vk::SampleCountFlags::TYPE_1,
        )
    }

    /// Creates a 2D image of `format` with `samples` samples per pixel and `usage`, its memory
    /// and a view of `aspects`.
    pub fn with_samples(
        gpu: &'a Gpu,
        format: vk::Format,
        aspects: vk::ImageAspectFlags,
        usage: vk::ImageUsageFlags,
        extent: vk::Extent2D,
        samples: vk::SampleCountFlags,
    ) -> Result<Self> {
        Self::create(
            gpu,
            format,
            Some(aspects),
            (usage, vk::ImageCreateFlags::empty()),
            (extent, DepthSubresources::default()),
            samples,
        )
    }

    /// Creates a 2D single-sample image of `format` with `usage` and `subresources` (mip
    /// levels of the extent halved from level to level, array layers), its memory, a view of
    /// `aspects` of level 0 layer 0 ([`Self::view`]) and, where it has several subresources,
    /// one such view per level and layer ([`Self::slice_view`]).
    pub fn with_subresources(
        gpu: &'a Gpu,
        format: vk::Format,
        aspects: vk::ImageAspectFlags,
        usage: vk::ImageUsageFlags,
        extent: vk::Extent2D,
        subresources: DepthSubresources,
    ) -> Result<Self> {
        let mut this = Self::create(
            gpu,
            format,
            Some(aspects),
            (usage, vk::ImageCreateFlags::empty()),
            (extent, subresources),
            vk::SampleCountFlags::TYPE_1,
        )?;
        if !subresources.is_single() {
            for level in 0..subresources.levels {
                for layer in 0..subresources.layers {
                    let range = vk::ImageSubresourceRange {
                        base_mip_level: level,
                        base_array_layer: layer,
                        ..full_range(aspects)
                    };
                    let view = this.create_view(vk::ImageViewType::TYPE_2D, range)?;
                    this.slice_views.push(view);
                }
            }
        }
        Ok(this)
    }

    /// Creates a 2D single-sample image only copied to and from (no view: `usage` may have
    /// no usage a view needs).
    pub fn copied(
        gpu: &'a Gpu,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        extent: vk::Extent2D,
    ) -> Result<Self> {
        Self::copied_with_flags(gpu, format, usage, vk::ImageCreateFlags::empty(), extent)
    }

    /// As [`Self::copied`], with image create `flags`.
    pub fn copied_with_flags(
        gpu: &'a Gpu,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        flags: vk::ImageCreateFlags,
        extent: vk::Extent2D,
    ) -> Result<Self> {
        Self::create(
            gpu,
            format,
            None,
            (usage, flags),
            (extent, DepthSubresources::default()),
            vk::SampleCountFlags::TYPE_1,
        )
    }

    fn create(
        gpu: &'a Gpu,
        format: vk::Format,
        view_aspects: Option<vk::ImageAspectFlags>,
        (usage, flags): (vk::ImageUsageFlags, vk::ImageCreateFlags),
        (extent, subresources): (vk::Extent2D, DepthSubresources),
        samples: vk::SampleCountFlags,
    ) -> Result<Self> {
        let mut this = Attachment {
            device: &gpu.device,
            image: vk::Image::null(),
            memory: vk::DeviceMemory::null(),
            view: vk::ImageView::null(),
            depth_view: vk::ImageView::null(),
            stencil_view: vk::ImageView::null(),
            slice_views: Vec::new(),
            array_view: vk::ImageView::null(),
            subresources,
            format,
            usage,
            samples,
            extent,
        };
        let info = vk::ImageCreateInfo::default()
            .flags(flags)
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: extent.width,
                height: extent.height,
                depth: 1,
            })
            .mip_levels(subresources.levels)
            .array_layers(subresources.layers)
            .samples(samples)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device and create info.
        this.image = unsafe { gpu.device.create_image(&info, None) }
            .with_context(|| format!("vkCreateImage ({format:?}) failed"))?;
        this.memory = bind_memory(gpu, this.image)?;
        let Some(aspects) = view_aspects else {
            return Ok(this);
        };
        let view_info = vk::ImageViewCreateInfo::default()
            .image(this.image)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(full_range(aspects));
        // SAFETY: valid image bound to memory, view matching its format and subresources.
        this.view = unsafe { gpu.device.create_image_view(&view_info, None) }
            .with_context(|| format!("vkCreateImageView ({format:?}) failed"))?;
        Ok(this)
    }
}

impl Attachment<'_> {
    /// A view of `range` of the image, of `view_type`.
    fn create_view(
        &self,
        view_type: vk::ImageViewType,
        range: vk::ImageSubresourceRange,
    ) -> Result<vk::ImageView> {
        let view_info = vk::ImageViewCreateInfo::default()
            .image(self.image)
            .view_type(view_type)
            .format(self.format)
            .subresource_range(range);
        // SAFETY: valid image bound to memory, view matching its format and subresources it
        // has.
        unsafe { self.device.create_image_view(&view_info, None) }
            .with_context(|| format!("vkCreateImageView ({:?}, {range:?}) failed", self.format))
    }

    /// Creates [`Self::depth_view`] (and [`Self::stencil_view`] where the format has
    /// stencil): views of one aspect each (a sampled view of a depth-stencil image may name
    /// one aspect only), of every level and layer.
    pub fn add_depth_view(&mut self) -> Result<()> {
        let view_type = if self.subresources.layers > 1 {
            vk::ImageViewType::TYPE_2D_ARRAY
        } else {
            vk::ImageViewType::TYPE_2D
        };
        let depth = self.range(vk::ImageAspectFlags::DEPTH);
        self.depth_view = self.create_view(view_type, depth)?;
        if format_has_stencil(self.format) {
            let stencil = self.range(vk::ImageAspectFlags::STENCIL);
            self.stencil_view = self.create_view(view_type, stencil)?;
        }
        Ok(())
    }

    /// Creates [`Self::array_view`]: a 2D-array view of `aspects` (all of the format's, as an
    /// attachment's view names them), mip level 0, every array layer.
    pub fn add_array_view(&mut self, aspects: vk::ImageAspectFlags) -> Result<()> {
        let range = vk::ImageSubresourceRange {
            layer_count: self.subresources.layers,
            ..full_range(aspects)
        };
        self.array_view = self.create_view(vk::ImageViewType::TYPE_2D_ARRAY, range)?;
        Ok(())
    }

    /// Every mip level and array layer of `aspects`.
    pub fn range(&self, aspects: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            level_count: self.subresources.levels,
            layer_count: self.subresources.layers,
            ..full_range(aspects)
        }
    }

    /// Mip level `level` (every array layer) of `aspects`.
    pub fn level_range(
        &self,
        aspects: vk::ImageAspectFlags,
        level: u32,
    ) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            base_mip_level: level,
            layer_count: self.subresources.layers,
            ..full_range(aspects)
        }
    }

    /// The attachment view of mip level `level`, array layer `layer` (all aspects): [`Self::view`]
    /// for level 0 layer 0; `None` for a subresource the image does not have.
    pub fn slice_view(&self, level: u32, layer: u32) -> Option<vk::ImageView> {
        if (level, layer) == (0, 0) {
            return Some(self.view);
        }
        let DepthSubresources { levels, layers } = self.subresources;
        if level >= levels || layer >= layers {
            return None;
        }
        self.slice_views
            .get((level * layers + layer) as usize)
            .copied()
    }

    /// The size of mip level `level`.
    pub fn level_extent(&self, level: u32) -> vk::Extent2D {
        level_extent(self.extent, level)
    }
}

/// The size of mip level `level` of an image of `extent` (halved per level, at least 1).
pub fn level_extent(extent: vk::Extent2D, level: u32) -> vk::Extent2D {
    vk::Extent2D {
        width: (extent.width >> level).max(1),
        height: (extent.height >> level).max(1),
    }
}

/// Whether `format` has a stencil aspect.
pub fn format_has_stencil(format: vk::Format) -> bool {
    matches!(
        format,
        vk::Format::D16_UNORM_S8_UINT
            | vk::Format::D24_UNORM_S8_UINT
            | vk::Format::D32_SFLOAT_S8_UINT
            | vk::Format::S8_UINT
    )
}

/// The whole (single mip, single layer) subresource range of `aspects`.
pub fn full_range(aspects: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspects,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

/// The size of the shadow map (square).
pub const SHADOW_MAP_SIZE: u32 = 512;
/// The shadow map's format.
pub const SHADOW_MAP_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// What the targets must support besides rendering.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TargetOptions {
    /// The depth image is read back (TRANSFER_SRC usage).
    pub depth_readback: bool,
    /// The depth image is cleared with `vkCmdClearDepthStencilImage` (TRANSFER_DST usage).
    pub clear_depth_image: bool,
    /// A shadow map is needed, of this format.
    pub shadow_map: Option<vk::Format>,
    /// The depth image is sampled (SAMPLED usage, a depth-aspect view).
    pub sampled_depth: bool,
    /// The depth image is read as an input attachment (INPUT_ATTACHMENT usage, a
    /// depth-aspect view).
    pub input_depth: bool,
    /// Multisampled attachments are needed (the plan's [`crate::plan::Needs::multisample`]).
    pub multisample: Option<Multisample>,
    /// The depth image's mip levels and array layers (the plan's
    /// [`crate::plan::Needs::depth_subresources`]).
    pub depth_subresources: DepthSubresources,
    /// The depth image is blitted from level to level (TRANSFER_SRC and TRANSFER_DST usage,
    /// BLIT_SRC and BLIT_DST features).
    pub depth_blits: bool,
    /// The views of a multiview pass (the plan's [`crate::plan::Needs::views`]; 0 without
    /// one): the color image gets one array layer per view (the depth image's layers are in
    /// `depth_subresources`), and both get a 2D-array view of them
    /// ([`Attachment::array_view`]) for the pass's attachments.
    pub views: u32,
}

/// `VkResolveModeFlagBits` of a [`ResolveMode`].
pub fn map_resolve_mode(mode: ResolveMode) -> vk::ResolveModeFlags {
    match mode {
        ResolveMode::SampleZero => vk::ResolveModeFlags::SAMPLE_ZERO,
        ResolveMode::Average => vk::ResolveModeFlags::AVERAGE,
        ResolveMode::Min => vk::ResolveModeFlags::MIN,
        ResolveMode::Max => vk::ResolveModeFlags::MAX,
    }
}

/// The names of the resolve modes in `modes` (`SAMPLE_ZERO | AVERAGE`).
fn resolve_mode_names(modes: vk::ResolveModeFlags) -> String {
    let names: Vec<&str> = [
        ResolveMode::SampleZero,
        ResolveMode::Average,
        ResolveMode::Min,
        ResolveMode::Max,
    ]
    .into_iter()
    .filter(|&mode| modes.contains(map_resolve_mode(mode)))
    .map(ResolveMode::vk_name)
    .collect();
    if names.is_empty() {
        "none".to_owned()
    } else {
        names.join(" | ")
    }
}

/// The resolve modes of a multisampled pass: the depth one the plan asks for, and the stencil
/// one that goes with it on this device (for formats with a stencil aspect).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResolveModes {
    /// `depthResolveMode` / the depth attachment's `resolveMode`.
    pub depth: vk::ResolveModeFlags,
    /// `stencilResolveMode` / the stencil attachment's `resolveMode`: NONE for formats
    /// without stencil and where the device resolves depth alone (`independentResolveNone`);
    /// else the depth mode, which the device must then support for stencil too (Vulkan
    /// requires both modes to be equal there).
    pub stencil: vk::ResolveModeFlags,
}

/// What the device offers for depth/stencil resolves, as
/// `VkPhysicalDeviceDepthStencilResolveProperties`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResolveSupport {
    /// `supportedDepthResolveModes`.
    pub depth_modes: vk::ResolveModeFlags,
    /// `supportedStencilResolveModes`.
    pub stencil_modes: vk::ResolveModeFlags,
    /// `independentResolveNone`.
    pub independent_none: bool,
}

impl ResolveSupport {
    /// The resolve modes of `depth_format` resolved with `mode`, or why the device cannot.
    pub fn modes(
        &self,
        mode: ResolveMode,
        depth_format: DepthFormat,
    ) -> Result<ResolveModes, String> {
        let depth = map_resolve_mode(mode);
        if !self.depth_modes.contains(depth) {
            return Err(format!(
                "cannot resolve depth with {} (--depth-resolve {}): its \
                 supportedDepthResolveModes are {}",
                mode.vk_name(),
                mode_cli_name(mode),
                resolve_mode_names(self.depth_modes)
            ));
        }
        let stencil = if !depth_format.has_stencil() || self.independent_none {
            vk::ResolveModeFlags::NONE
        } else if self.stencil_modes.contains(depth) {
            depth
        } else {
            return Err(format!(
                "cannot resolve {} with depth mode {}: without independentResolveNone the \
                 stencil aspect must be resolved with the same mode, and its \
                 supportedStencilResolveModes are {} (use a depth format without stencil, \
                 or --depth-resolve sample-zero)",
                depth_format.vk_name(),
                mode.vk_name(),
                resolve_mode_names(self.stencil_modes)
            ));
        };
        Ok(ResolveModes { depth, stencil })
    }
}

/// The command-line name of a resolve mode (`sample-zero`).
fn mode_cli_name(mode: ResolveMode) -> String {
    mode.to_possible_value()
        .map_or_else(|| mode.vk_name().to_owned(), |v| v.get_name().to_owned())
}

/// The transient multisampled attachments of multisampled passes.
#[derive(Debug)]
pub struct MultisampledTargets<'a> {
    /// Samples per pixel.
    pub samples: vk::SampleCountFlags,
    /// R8G8B8A8_UNORM, COLOR_ATTACHMENT | TRANSIENT_ATTACHMENT, resolved into the main color
    /// image.
    pub color: Attachment<'a>,
    /// The chosen depth format, DEPTH_STENCIL_ATTACHMENT | TRANSIENT_ATTACHMENT (never read
    /// back, never copied), resolved into the main depth image; or, where the plan keeps it
    /// for shaders ([`Multisample::sampled_depth`]), DEPTH_STENCIL_ATTACHMENT | SAMPLED with a
    /// depth-aspect view ([`Attachment::depth_view`]), not resolved.
    pub depth: Attachment<'a>,
    /// How it is resolved (NONE for both aspects where it is kept).
    pub resolve: ResolveModes,
}

/// Fails with a clear message unless the device can render `multisample` with `depth_format`
/// (Vulkan 1.2 for `vkCreateRenderPass2` and depth resolves, the sample count for both
/// attachments, the depth resolve mode); returns the resolve modes to use.
fn check_multisample(
    gpu: &Gpu,
    depth_format: DepthFormat,
    multisample: Multisample,
) -> Result<(vk::SampleCountFlags, ResolveModes)> {
    let device = &gpu.info.name;
    if !gpu.enabled.depth_stencil_resolve {
        bail!(
            "device '{device}' is used at Vulkan {}.{} without VK_KHR_depth_stencil_resolve: \
             multisampled depth resolves need Vulkan 1.2 or it",
            vk::api_version_major(gpu.api_version()),
            vk::api_version_minor(gpu.api_version())
        );
    }
    let samples = vk::SampleCountFlags::from_raw(multisample.samples);
    let limits = gpu.limits();
    let mut framebuffer = vec![
        (
            limits.framebuffer_color_sample_counts,
            "framebufferColorSampleCounts",
        ),
        (
            limits.framebuffer_depth_sample_counts,
            "framebufferDepthSampleCounts",
        ),
    ];
    if depth_format.has_stencil() {
        framebuffer.push((
            limits.framebuffer_stencil_sample_counts,
            "framebufferStencilSampleCounts",
        ));
    }
    for (counts, name) in framebuffer {
        if !counts.contains(samples) {
            bail!(
                "device '{device}' cannot render {} samples per pixel ({name} {counts:?})",
                multisample.samples
            );
        }
    }
    if multisample.sampled_depth {
        let counts = limits.sampled_image_depth_sample_counts;
        if !counts.contains(samples) {
            bail!(
                "device '{device}' cannot sample depth images of {} samples per pixel \
                 (sampledImageDepthSampleCounts {counts:?})",
                multisample.samples
            );
        }
    }
    for (format, name, usage) in [
        (
            COLOR_FORMAT,
            "R8G8B8A8_UNORM",
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSIENT_ATTACHMENT,
        ),
        (
            depth_format.vk_format(),
            depth_format.vk_name(),
            multisampled_depth_usage(multisample),
        ),
    ] {
        // SAFETY: valid physical device of this instance.
        let properties = unsafe {
            gpu.instance().get_physical_device_image_format_properties(
                gpu.physical_device,
                format,
                vk::ImageType::TYPE_2D,
                vk::ImageTiling::OPTIMAL,
                usage,
                vk::ImageCreateFlags::empty(),
            )
        }
        .with_context(|| format!("device '{device}' cannot make {name} images with {usage:?}"))?;
        if !properties.sample_counts.contains(samples) {
            bail!(
                "device '{device}' cannot make {name} images with {} samples per pixel \
                 (sampleCounts {:?})",
                multisample.samples,
                properties.sample_counts
            );
        }
    }
    if multisample.sampled_depth {
        let none = vk::ResolveModeFlags::NONE;
        return Ok((
            samples,
            ResolveModes {
                depth: none,
                stencil: none,
            },
        ));
    }
    let resolve = gpu
        .resolve_support()
        .modes(multisample.depth_resolve, depth_format)
        .map_err(|why| anyhow::anyhow!("device '{device}' {why}"))?;
    Ok((samples, resolve))
}

/// The usage of the multisampled depth attachment: transient where it is resolved, sampled
/// where shaders read it after its pass.
fn multisampled_depth_usage(multisample: Multisample) -> vk::ImageUsageFlags {
    vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
        | if multisample.sampled_depth {
            vk::ImageUsageFlags::SAMPLED
        } else {
            vk::ImageUsageFlags::TRANSIENT_ATTACHMENT
        }
}

/// Fails with a clear message unless the device makes depth images of `depth_format` with
/// `usage` and `subresources` (mip levels down to the last one's size, array layers).
fn check_subresources(
    gpu: &Gpu,
    depth_format: DepthFormat,
    usage: vk::ImageUsageFlags,
    extent: vk::Extent2D,
    subresources: DepthSubresources,
) -> Result<()> {
    if subresources.is_single() {
        return Ok(());
    }
    let DepthSubresources { levels, layers } = subresources;
    let largest = extent.width.max(extent.height);
    if levels > 32 - largest.leading_zeros() {
        bail!(
            "a {}x{} depth image has fewer than {levels} mip levels",
            extent.width,
            extent.height
        );
    }
    // SAFETY: valid physical device of this instance.
    let properties = unsafe {
        gpu.instance().get_physical_device_image_format_properties(
            gpu.physical_device,
            depth_format.vk_format(),
            vk::ImageType::TYPE_2D,
            vk::ImageTiling::OPTIMAL,
            usage,
            vk::ImageCreateFlags::empty(),
        )
    }
    .with_context(|| {
        format!(
            "device '{}' cannot make {} images with {usage:?}",
            gpu.info.name,
            depth_format.vk_name()
        )
    })?;
    if levels > properties.max_mip_levels || layers > properties.max_array_layers {
        bail!(
            "device '{}' cannot make {} images of {levels} mip levels and {layers} array layers \
             (maxMipLevels {}, maxArrayLayers {})",
            gpu.info.name,
            depth_format.vk_name(),
            properties.max_mip_levels,
            properties.max_array_layers
        );
    }
    Ok(())
}

/// The offscreen color and depth attachments (and the shadow map, if any).
#[derive(Debug)]
pub struct Targets<'a> {
    /// Size in pixels.
    pub extent: vk::Extent2D,
    /// Which depth format `depth` has.
    pub depth_format: DepthFormat,
    /// R8G8B8A8_UNORM, COLOR_ATTACHMENT | TRANSFER_SRC.
    pub color: Attachment<'a>,
    /// The chosen depth format, DEPTH_STENCIL_ATTACHMENT, plus TRANSFER_SRC when read back and
    /// TRANSFER_DST when cleared as an image.
    pub depth: Attachment<'a>,
    /// D32_SFLOAT, [`SHADOW_MAP_SIZE`] square, DEPTH_STENCIL_ATTACHMENT | SAMPLED.
    pub shadow: Option<Attachment<'a>>,
    /// The multisampled attachments of multisampled passes.
    pub multisampled: Option<MultisampledTargets<'a>>,
}

impl<'a> Targets<'a> {
    /// Checks format support and creates the attachments.
    pub fn new(
        gpu: &'a Gpu,
        width: u32,
        height: u32,
        depth_format: DepthFormat,
        options: TargetOptions,
    ) -> Result<Self> {
        if width == 0 || height == 0 {
            bail!("the render size must not be empty (got {width}x{height})");
        }
        require_format(
            gpu,
            COLOR_FORMAT,
            "R8G8B8A8_UNORM",
            vk::FormatFeatureFlags::COLOR_ATTACHMENT | vk::FormatFeatureFlags::TRANSFER_SRC,
            "a color attachment",
        )?;
        let mut depth_usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
        let mut depth_features = vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT;
        if options.depth_readback {
            depth_usage |= vk::ImageUsageFlags::TRANSFER_SRC;
            depth_features |= vk::FormatFeatureFlags::TRANSFER_SRC;
        }
        if options.clear_depth_image {
            depth_usage |= vk::ImageUsageFlags::TRANSFER_DST;
            depth_features |= vk::FormatFeatureFlags::TRANSFER_DST;
        }
        if options.sampled_depth {
            depth_usage |= vk::ImageUsageFlags::SAMPLED;
            depth_features |= vk::FormatFeatureFlags::SAMPLED_IMAGE;
        }
        if options.depth_blits {
            depth_usage |= vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
            depth_features |= vk::FormatFeatureFlags::BLIT_SRC | vk::FormatFeatureFlags::BLIT_DST;
        }
        if options.input_depth {
            // An input attachment needs no format feature beyond the attachment's own.
            depth_usage |= vk::ImageUsageFlags::INPUT_ATTACHMENT;
        }
        require_format(
            gpu,
            depth_format.vk_format(),
            depth_format.vk_name(),
            depth_features,
            "a depth attachment",
        )?;
        let extent = vk::Extent2D { width, height };
        check_subresources(
            gpu,
            depth_format,
            depth_usage,
            extent,
            options.depth_subresources,
        )?;
        let color_aspects = vk::ImageAspectFlags::COLOR;
        let color_usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let color = if options.views > 1 {
            let layers = DepthSubresources {
                levels: 1,
                layers: options.views,
            };
            let mut color = Attachment::with_subresources(
                gpu,
                COLOR_FORMAT,
                color_aspects,
                color_usage,
                extent,
                layers,
            )?;
            color.add_array_view(color_aspects)?;
            color
        } else {
            Attachment::new(gpu, COLOR_FORMAT, color_aspects, color_usage, extent)?
        };
        let mut depth = Attachment::with_subresources(
            gpu,
            depth_format.vk_format(),
            depth_format.aspects(),
            depth_usage,
            extent,
            options.depth_subresources,
        )?;
        if options.sampled_depth || options.input_depth {
            depth.add_depth_view()?;
        }
        if options.views > 1 {
            depth.add_array_view(depth_format.aspects())?;
        }
        let shadow = if let Some(format) = options.shadow_map {
            require_format(
                gpu,
                format,
                &format!("{format:?}"),
                vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT
                    | vk::FormatFeatureFlags::SAMPLED_IMAGE,
                "a sampled shadow map",
            )?;
            Some(Attachment::new(
                gpu,
                format,
                vk::ImageAspectFlags::DEPTH,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
                vk::Extent2D {
                    width: SHADOW_MAP_SIZE,
                    height: SHADOW_MAP_SIZE,
                },
            )?)
        } else {
            None
        };
        let multisampled = match options.multisample {
            Some(multisample) => {
                let (samples, resolve) = check_multisample(gpu, depth_format, multisample)?;
                let mut depth = Attachment::with_samples(
                    gpu,
                    depth_format.vk_format(),
                    depth_format.aspects(),
                    multisampled_depth_usage(multisample),
                    extent,
                    samples,
                )?;
                if multisample.sampled_depth {
                    depth.add_depth_view()?;
                }
                Some(MultisampledTargets {
                    samples,
                    color: Attachment::with_samples(
                        gpu,
                        COLOR_FORMAT,
                        vk::ImageAspectFlags::COLOR,
                        vk::ImageUsageFlags::COLOR_ATTACHMENT
                            | vk::ImageUsageFlags::TRANSIENT_ATTACHMENT,
                        extent,
                        samples,
                    )?,
                    depth,
                    resolve,
                })
            }
            None => None,
        };
        Ok(Targets {
            extent,
            depth_format,
            color,
            depth,
            shadow,
            multisampled,
        })
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.extent.width as usize * self.extent.height as usize
    }

    /// The views rendered: the color image's array layers (one per view of a multiview pass,
    /// [`TargetOptions::views`]; 1 otherwise).
    pub fn views(&self) -> u32 {
        self.color.subresources.layers
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_match_vulkan_debug_names() {
        let cli_names: Vec<String> = DepthFormat::value_variants()
            .iter()
            .map(|f| f.to_possible_value().unwrap().get_name().to_owned())
            .collect();
        assert_eq!(cli_names, ["d16", "x8-d24", "d24-s8", "d32", "d32-s8"]);
        for format in DepthFormat::value_variants() {
            assert_eq!(format!("{:?}", format.vk_format()), format.vk_name());
        }
    }

    #[test]
    fn resolve_modes_follow_the_device() {
        // lavapipe's: no MIN or MAX, stencil resolved with the depth mode only.
        let lavapipe = ResolveSupport {
            depth_modes: vk::ResolveModeFlags::SAMPLE_ZERO | vk::ResolveModeFlags::AVERAGE,
            stencil_modes: vk::ResolveModeFlags::SAMPLE_ZERO,
            independent_none: false,
        };
        let modes = |support: &ResolveSupport, mode, format| support.modes(mode, format);
        let none = vk::ResolveModeFlags::NONE;
        assert_eq!(
            modes(&lavapipe, ResolveMode::Average, DepthFormat::D32),
            Ok(ResolveModes {
                depth: vk::ResolveModeFlags::AVERAGE,
                stencil: none,
            })
        );
        assert_eq!(
            modes(&lavapipe, ResolveMode::SampleZero, DepthFormat::D24S8),
            Ok(ResolveModes {
                depth: vk::ResolveModeFlags::SAMPLE_ZERO,
                stencil: vk::ResolveModeFlags::SAMPLE_ZERO,
            })
        );
        let refused = modes(&lavapipe, ResolveMode::Min, DepthFormat::D16).unwrap_err();
        assert!(
            refused.contains("MIN (--depth-resolve min)")
                && refused.contains("SAMPLE_ZERO | AVERAGE"),
            "{refused}"
        );
        let refused = modes(&lavapipe, ResolveMode::Average, DepthFormat::D32S8).unwrap_err();
        assert!(refused.contains("D32_SFLOAT_S8_UINT"), "{refused}");
        // A device that resolves depth alone leaves stencil unresolved.
        let independent = ResolveSupport {
            depth_modes: vk::ResolveModeFlags::SAMPLE_ZERO
                | vk::ResolveModeFlags::MIN
                | vk::ResolveModeFlags::MAX,
            independent_none: true,
            ..lavapipe
        };
        assert_eq!(
            modes(&independent, ResolveMode::Max, DepthFormat::D24S8),
            Ok(ResolveModes {
                depth: vk::ResolveModeFlags::MAX,
                stencil: none,
            })
        );
    }

    #[test]
    fn stencil_formats_name_both_aspects() {
        assert_eq!(
            DepthFormat::D24S8.aspects(),
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
        );
        assert_eq!(DepthFormat::D32.aspects(), vk::ImageAspectFlags::DEPTH);
    }
}
