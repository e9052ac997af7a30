//! The offscreen render target: the depth-format choice (`--depth-format`) and the two
//! attachments (an R8G8B8A8_UNORM color image and a depth image of the chosen format), each in
//! device-local memory with its image view, the color image usable as a transfer source for
//! read-back, the depth image too unless `--no-depth-readback` (and a transfer destination
//! only for scenes that clear it with `vkCmdClearDepthStencilImage`); plus, for shadow-map
//! scenes, a D32_SFLOAT shadow map with SAMPLED usage (never read back, never transferred).

use std::fmt;

use anyhow::{bail, Context, Result};
use ash::vk;
use clap::ValueEnum;

use crate::gpu::Gpu;

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

/// One device-local image with its memory and view.
pub struct Attachment<'a> {
    device: &'a ash::Device,
    /// The image.
    pub image: vk::Image,
    memory: vk::DeviceMemory,
    /// A view of the whole image (all its aspects).
    pub view: vk::ImageView,
    /// The image format.
    pub format: vk::Format,
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

impl Drop for Attachment<'_> {
    fn drop(&mut self) {
        // SAFETY: the handles are null or were created from `device` (which outlives `self`),
        // and no GPU work using them is pending. Destroying null handles is a no-op.
        unsafe {
            self.device.destroy_image_view(self.view, None);
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
        let mut this = Attachment {
            device: &gpu.device,
            image: vk::Image::null(),
            memory: vk::DeviceMemory::null(),
            view: vk::ImageView::null(),
            format,
        };
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: extent.width,
                height: extent.height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device and create info.
        this.image = unsafe { gpu.device.create_image(&info, None) }
            .with_context(|| format!("vkCreateImage ({format:?}) failed"))?;
        // SAFETY: valid image.
        let requirements = unsafe { gpu.device.get_image_memory_requirements(this.image) };
        this.memory = gpu.allocate(
            requirements,
            vk::MemoryPropertyFlags::empty(),
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        )?;
        // SAFETY: fresh image and memory of a compatible type and sufficient size.
        unsafe { gpu.device.bind_image_memory(this.image, this.memory, 0) }
            .context("vkBindImageMemory failed")?;
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
    /// A shadow map is needed.
    pub shadow_map: bool,
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
        require_format(
            gpu,
            depth_format.vk_format(),
            depth_format.vk_name(),
            depth_features,
            "a depth attachment",
        )?;
        let extent = vk::Extent2D { width, height };
        let color = Attachment::new(
            gpu,
            COLOR_FORMAT,
            vk::ImageAspectFlags::COLOR,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
            extent,
        )?;
        let depth = Attachment::new(
            gpu,
            depth_format.vk_format(),
            depth_format.aspects(),
            depth_usage,
            extent,
        )?;
        let shadow = if options.shadow_map {
            require_format(
                gpu,
                SHADOW_MAP_FORMAT,
                "D32_SFLOAT",
                vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT
                    | vk::FormatFeatureFlags::SAMPLED_IMAGE,
                "a sampled shadow map",
            )?;
            Some(Attachment::new(
                gpu,
                SHADOW_MAP_FORMAT,
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
        Ok(Targets {
            extent,
            depth_format,
            color,
            depth,
            shadow,
        })
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.extent.width as usize * self.extent.height as usize
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
    fn stencil_formats_name_both_aspects() {
        assert_eq!(
            DepthFormat::D24S8.aspects(),
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
        );
        assert_eq!(DepthFormat::D32.aspects(), vk::ImageAspectFlags::DEPTH);
    }
}
