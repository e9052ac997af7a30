//! Getting the rendered images back and writing them out: the host-visible read-back buffers,
//! the barriers and copies recorded after the render pass, decoding of the depth aspect to
//! f32 for every depth format, and the output files (`color.png`, `depth.png`, `depth.f32`,
//! `render.json`; the ground-truth files are written by `main.rs`). With `--no-depth-readback` only the color image is read back (the depth
//! image then has no TRANSFER_SRC usage), and `depth.png` / `depth.f32` are not written. The
//! stencil aspect is never read back.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use ash::vk;
use image::{ImageBuffer, Luma, Rgba};
use serde::Serialize;

use crate::gpu::{Gpu, HostBuffer};
use crate::ground_truth::GroundTruthReport;
use crate::target::{full_range, Attachment, DepthFormat, Targets};

/// How the depth aspect reaches the host (`--depth-route`): the copies an application makes
/// of a depth image, for revz's conversion of copies (issue #21). Every route must deliver
/// the same values.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DepthRoute {
    /// `vkCmdCopyImageToBuffer` into the host buffer.
    #[default]
    Direct,
    /// `vkCmdCopyImage` into a second depth image (TRANSFER_SRC | TRANSFER_DST, which revz
    /// reverses by default), then into the host buffer.
    Image,
    /// The same through a second image that shaders may sample (SAMPLED: revz keeps it
    /// native), so the image copy crosses conventions.
    NativeImage,
    /// `vkCmdCopyImageToBuffer` into a device buffer, `vkCmdCopyBufferToImage` into a second
    /// depth image, then into the host buffer: a round trip through the application's bytes.
    Buffer,
    /// `vkCmdBlitImage` (same size, NEAREST, mirrored in x and back by the read: the blit
    /// flips x, a second blit would not be a copy, so the host flips the rows back) into a
    /// second image that shaders may sample (native), then into the host buffer.
    BlitNativeImage,
}

impl DepthRoute {
    /// The second image's usage, if the route has one.
    fn image_usage(self) -> Option<vk::ImageUsageFlags> {
        let copied = vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
        match self {
            DepthRoute::Direct => None,
            DepthRoute::Image | DepthRoute::Buffer => Some(copied),
            DepthRoute::NativeImage | DepthRoute::BlitNativeImage => {
                Some(copied | vk::ImageUsageFlags::SAMPLED)
            }
        }
    }
}

/// How the depth is read back: its route, the padding of the host buffer's rows, and which
/// copy commands record it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DepthReadback {
    pub route: DepthRoute,
    /// Texels of padding after each row in the host buffer (`bufferRowLength` = width +
    /// padding). The padding is filled with [`PADDING_BYTE`] before the render and must hold
    /// it after: a copy may write only the texels.
    pub row_padding: u32,
    /// Record the copies with the `*2` commands (`vkCmdCopyImageToBuffer2`, ...; Vulkan 1.3).
    pub copy2: bool,
}

/// What the host buffer's row padding holds before and after the render.
pub const PADDING_BYTE: u8 = 0xA5;

/// Host-visible buffers receiving the color image and the depth aspect of the depth image.
#[derive(Debug)]
pub struct Readback<'a> {
    color: HostBuffer<'a>,
    /// None with `--no-depth-readback`.
    depth: Option<HostBuffer<'a>>,
    extent: vk::Extent2D,
    depth_format: DepthFormat,
    options: DepthReadback,
    /// The route's second depth image.
    second: Option<Attachment<'a>>,
    /// The `buffer` route's device buffer.
    staging: Option<HostBuffer<'a>>,
}

/// What was rendered, on the host.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The depth format rendered with.
    pub depth_format: DepthFormat,
    /// RGBA8, row-major, top row first.
    pub rgba: Vec<u8>,
    /// Decoded depth per pixel, row-major, top row first (None if not read back).
    pub depth: Option<Vec<f32>>,
}

impl<'a> Readback<'a> {
    /// Creates the read-back buffers for `targets` (none for depth unless `depth`).
    pub fn new(
        gpu: &'a Gpu,
        targets: &Targets<'_>,
        depth: bool,
        options: DepthReadback,
    ) -> Result<Self> {
        let pixels = targets.pixel_count();
        let color = HostBuffer::new(gpu, pixels * 4, vk::BufferUsageFlags::TRANSFER_DST)
            .context("color read-back buffer")?;
        let texel = targets.depth_format.depth_copy_texel_size();
        let extent = targets.extent;
        let padded = (extent.width + options.row_padding) as usize * extent.height as usize;
        let (mut depth_buffer, mut second, mut staging) = (None, None, None);
        if depth {
            let mut buffer =
                HostBuffer::new(gpu, padded * texel, vk::BufferUsageFlags::TRANSFER_DST)
                    .context("depth read-back buffer")?;
            buffer.write(&vec![PADDING_BYTE; padded * texel]);
            depth_buffer = Some(buffer);
            if let Some(usage) = options.route.image_usage() {
                let format = targets.depth_format;
                second = Some(
                    Attachment::copied(gpu, format.vk_format(), usage, extent)
                        .context("the depth route's second image")?,
                );
            }
            if options.route == DepthRoute::Buffer {
                let usage = vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
                staging = Some(
                    HostBuffer::new(gpu, pixels * texel, usage)
                        .context("the depth route's device buffer")?,
                );
            }
        }
        Ok(Readback {
            color,
            depth: depth_buffer,
            extent,
            depth_format: targets.depth_format,
            options,
            second,
            staging,
        })
    }

    /// Records, after the render pass: attachment layouts -> TRANSFER_SRC_OPTIMAL (waiting for
    /// the attachment writes, including the store ops and resolves), the copies of the color image and of
    /// the DEPTH aspect (if read back), and a TRANSFER -> HOST barrier so the host can read the
    /// buffers once the submission's fence has signalled.
    pub fn record(&self, device: &ash::Device, cmd: vk::CommandBuffer, targets: &Targets<'_>) {
        let mut to_transfer = vec![vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::COLOR_ATTACHMENT_WRITE)
            .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
            .old_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(targets.color.image)
            .subresource_range(full_range(vk::ImageAspectFlags::COLOR))];
        if self.depth.is_some() {
            // Resolves write in the color attachment output stage with color attachment
            // writes, the depth resolve of a multisampled pass included.
            let mut written = vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE;
            if targets.multisampled.is_some() {
                written |= vk::AccessFlags::COLOR_ATTACHMENT_WRITE;
            }
            // A layout transition of a depth/stencil image names all of its aspects.
            to_transfer.push(
                vk::ImageMemoryBarrier::default()
                    .src_access_mask(written)
                    .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
                    .old_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
                    .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(targets.depth.image)
                    .subresource_range(full_range(targets.depth_format.aspects())),
            );
        }
        if let Some(second) = &self.second {
            // The route's second image: written first, by a copy.
            to_transfer.push(
                vk::ImageMemoryBarrier::default()
                    .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .old_layout(vk::ImageLayout::UNDEFINED)
                    .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(second.image)
                    .subresource_range(full_range(targets.depth_format.aspects())),
            );
        }
        let to_host: Vec<vk::BufferMemoryBarrier<'_>> = std::iter::once(&self.color)
            .chain(self.depth.as_ref())
            .map(|buffer| {
                vk::BufferMemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::HOST_READ)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .buffer(buffer.buffer)
                    .offset(0)
                    .size(vk::WHOLE_SIZE)
            })
            .collect();
        // SAFETY: `cmd` is recording outside a render pass; the images and buffers are valid,
        // the buffers are large enough for the copies of the whole images, and the depth
        // image has TRANSFER_SRC usage whenever a depth buffer exists.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE
                    | vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                    | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_transfer,
            );
            device.cmd_copy_image_to_buffer(
                cmd,
                targets.color.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.color.buffer,
                &[self.region(vk::ImageAspectFlags::COLOR, 0)],
            );
        }
        if let Some(depth) = &self.depth {
            self.record_depth(device, cmd, targets.depth.image, depth.buffer);
        }
        // SAFETY: as above.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &[],
                &to_host,
                &[],
            );
        }
    }

    /// A copy region of the whole image's `aspect`, with `row_length` texels per buffer row
    /// (0: tight).
    fn region(&self, aspect: vk::ImageAspectFlags, row_length: u32) -> vk::BufferImageCopy {
        vk::BufferImageCopy {
            buffer_offset: 0,
            buffer_row_length: row_length,
            buffer_image_height: 0,
            image_subresource: vk::ImageSubresourceLayers {
                aspect_mask: aspect,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            },
            image_offset: vk::Offset3D { x: 0, y: 0, z: 0 },
            image_extent: vk::Extent3D {
                width: self.extent.width,
                height: self.extent.height,
                depth: 1,
            },
        }
    }

    /// The depth aspect's copies along the route, into `host` (the depth image is in
    /// TRANSFER_SRC_OPTIMAL, the second image in TRANSFER_DST_OPTIMAL).
    fn record_depth(
        &self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        image: vk::Image,
        host: vk::Buffer,
    ) {
        let depth = vk::ImageAspectFlags::DEPTH;
        let padded = match self.options.row_padding {
            0 => 0,
            padding => self.extent.width + padding,
        };
        let copies = Copies {
            device,
            cmd,
            copy2: self.options.copy2,
        };
        let Some(second) = &self.second else {
            copies.image_to_buffer(image, host, self.region(depth, padded));
            return;
        };
        let layers = self.region(depth, 0).image_subresource;
        match self.options.route {
            DepthRoute::Buffer => {
                let staging = self
                    .staging
                    .as_ref()
                    .expect("the buffer route has a device buffer");
                copies.image_to_buffer(image, staging.buffer, self.region(depth, 0));
                copies.barrier(
                    vk::BufferMemoryBarrier::default()
                        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                        .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
                        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .buffer(staging.buffer)
                        .size(vk::WHOLE_SIZE),
                    None,
                );
                copies.buffer_to_image(staging.buffer, second.image, self.region(depth, 0));
            }
            DepthRoute::BlitNativeImage => {
                let (w, h) = (self.extent.width as i32, self.extent.height as i32);
                let corner = |x, y, z| vk::Offset3D { x, y, z };
                copies.blit(
                    image,
                    second.image,
                    vk::ImageBlit {
                        src_subresource: layers,
                        src_offsets: [corner(w, 0, 0), corner(0, h, 1)],
                        dst_subresource: layers,
                        dst_offsets: [corner(0, 0, 0), corner(w, h, 1)],
                    },
                );
            }
            _ => copies.image_to_image(
                image,
                second.image,
                vk::ImageCopy {
                    src_subresource: layers,
                    src_offset: vk::Offset3D::default(),
                    dst_subresource: layers,
                    dst_offset: vk::Offset3D::default(),
                    extent: self.region(depth, 0).image_extent,
                },
            ),
        }
        copies.barrier(
            vk::BufferMemoryBarrier::default(),
            Some(
                vk::ImageMemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
                    .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
                    .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(second.image)
                    .subresource_range(full_range(self.depth_format.aspects())),
            ),
        );
        copies.image_to_buffer(second.image, host, self.region(depth, padded));
    }

    /// The read-back contents (call only after the render's fence has signalled).
    pub fn frame(&self) -> Result<Frame> {
        let pixels = self.extent.width as usize * self.extent.height as usize;
        let rgba = self.color.contents()[..pixels * 4].to_vec();
        let depth = match &self.depth {
            Some(depth) => {
                let packed = self.unpadded(depth.contents())?;
                Some(decode_depth(self.depth_format, &packed, pixels)?)
            }
            None => None,
        };
        Ok(Frame {
            width: self.extent.width,
            height: self.extent.height,
            depth_format: self.depth_format,
            rgba,
            depth,
        })
    }
}

impl Readback<'_> {
    /// The host buffer's texels without the row padding; an error if a copy wrote into the
    /// padding.
    fn unpadded(&self, bytes: &[u8]) -> Result<Vec<u8>> {
        let texel = self.depth_format.depth_copy_texel_size();
        let packed = self.without_padding(bytes)?;
        if self.options.route != DepthRoute::BlitNativeImage {
            return Ok(packed);
        }
        // The blit mirrored x: every row back to front.
        let width = self.extent.width as usize;
        Ok(packed
            .chunks_exact(width * texel)
            .flat_map(|row| row.chunks_exact(texel).rev().flatten().copied())
            .collect())
    }

    fn without_padding(&self, bytes: &[u8]) -> Result<Vec<u8>> {
        let padding = self.options.row_padding as usize;
        if padding == 0 {
            return Ok(bytes.to_vec());
        }
        let texel = self.depth_format.depth_copy_texel_size();
        let (width, height) = (self.extent.width as usize, self.extent.height as usize);
        let row = (width + padding) * texel;
        let mut packed = Vec::with_capacity(width * height * texel);
        for y in 0..height {
            let line = &bytes[y * row..(y + 1) * row];
            let (texels, pad) = line.split_at(width * texel);
            if let Some(i) = pad.iter().position(|&b| b != PADDING_BYTE) {
                bail!(
                    "a depth copy wrote into the read-back buffer's row padding (row {y}, byte \
                     {i} of the padding holds {:#04x})",
                    pad[i]
                );
            }
            packed.extend_from_slice(texels);
        }
        Ok(packed)
    }
}

/// Records copies with the `1.0` commands or their `*2` twins.
struct Copies<'a> {
    device: &'a ash::Device,
    cmd: vk::CommandBuffer,
    copy2: bool,
}

impl Copies<'_> {
    fn image_to_buffer(&self, image: vk::Image, buffer: vk::Buffer, region: vk::BufferImageCopy) {
        let layout = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
        // SAFETY: a recording command buffer outside a render pass; `image` is in `layout`
        // with TRANSFER_SRC usage and `buffer` holds the region.
        unsafe {
            if self.copy2 {
                let regions = [region2(region)];
                let info = vk::CopyImageToBufferInfo2::default()
                    .src_image(image)
                    .src_image_layout(layout)
                    .dst_buffer(buffer)
                    .regions(&regions);
                self.device.cmd_copy_image_to_buffer2(self.cmd, &info);
            } else {
                self.device
                    .cmd_copy_image_to_buffer(self.cmd, image, layout, buffer, &[region]);
            }
        }
    }

    fn buffer_to_image(&self, buffer: vk::Buffer, image: vk::Image, region: vk::BufferImageCopy) {
        let layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
        // SAFETY: as above, `image` in `layout` with TRANSFER_DST usage.
        unsafe {
            if self.copy2 {
                let regions = [region2(region)];
                let info = vk::CopyBufferToImageInfo2::default()
                    .src_buffer(buffer)
                    .dst_image(image)
                    .dst_image_layout(layout)
                    .regions(&regions);
                self.device.cmd_copy_buffer_to_image2(self.cmd, &info);
            } else {
                self.device
                    .cmd_copy_buffer_to_image(self.cmd, buffer, image, layout, &[region]);
            }
        }
    }

    fn image_to_image(&self, src: vk::Image, dst: vk::Image, region: vk::ImageCopy) {
        let (src_layout, dst_layout) = (
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        );
        // SAFETY: as above.
        unsafe {
            if self.copy2 {
                let regions = [vk::ImageCopy2::default()
                    .src_subresource(region.src_subresource)
                    .src_offset(region.src_offset)
                    .dst_subresource(region.dst_subresource)
                    .dst_offset(region.dst_offset)
                    .extent(region.extent)];
                let info = vk::CopyImageInfo2::default()
                    .src_image(src)
                    .src_image_layout(src_layout)
                    .dst_image(dst)
                    .dst_image_layout(dst_layout)
                    .regions(&regions);
                self.device.cmd_copy_image2(self.cmd, &info);
            } else {
                self.device
                    .cmd_copy_image(self.cmd, src, src_layout, dst, dst_layout, &[region]);
            }
        }
    }

    fn blit(&self, src: vk::Image, dst: vk::Image, region: vk::ImageBlit) {
        let (src_layout, dst_layout) = (
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        );
        // SAFETY: as above; depth blits are NEAREST, between images of one format.
        unsafe {
            if self.copy2 {
                let regions = [vk::ImageBlit2::default()
                    .src_subresource(region.src_subresource)
                    .src_offsets(region.src_offsets)
                    .dst_subresource(region.dst_subresource)
                    .dst_offsets(region.dst_offsets)];
                let info = vk::BlitImageInfo2::default()
                    .src_image(src)
                    .src_image_layout(src_layout)
                    .dst_image(dst)
                    .dst_image_layout(dst_layout)
                    .regions(&regions)
                    .filter(vk::Filter::NEAREST);
                self.device.cmd_blit_image2(self.cmd, &info);
            } else {
                self.device.cmd_blit_image(
                    self.cmd,
                    src,
                    src_layout,
                    dst,
                    dst_layout,
                    &[region],
                    vk::Filter::NEAREST,
                );
            }
        }
    }

    /// A TRANSFER -> TRANSFER barrier: `buffer` (skipped when its handle is null) and `image`.
    fn barrier(
        &self,
        buffer: vk::BufferMemoryBarrier<'_>,
        image: Option<vk::ImageMemoryBarrier<'_>>,
    ) {
        let buffers: Vec<_> = std::iter::once(buffer)
            .filter(|b| b.buffer != vk::Buffer::null())
            .collect();
        let images: Vec<_> = image.into_iter().collect();
        // SAFETY: as above.
        unsafe {
            self.device.cmd_pipeline_barrier(
                self.cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &buffers,
                &images,
            )
        }
    }
}

/// A `1.0` region as its `*2` twin.
fn region2(region: vk::BufferImageCopy) -> vk::BufferImageCopy2<'static> {
    vk::BufferImageCopy2::default()
        .buffer_offset(region.buffer_offset)
        .buffer_row_length(region.buffer_row_length)
        .buffer_image_height(region.buffer_image_height)
        .image_subresource(region.image_subresource)
        .image_offset(region.image_offset)
        .image_extent(region.image_extent)
}

/// Decodes `count` texels of a DEPTH-aspect buffer copy to f32 (computed in f64, rounded
/// once): D16 -> u16 / 65535; X8_D24 and D24_S8 (4 bytes per texel, depth in the low 24 bits,
/// the top 8 ignored) -> (v & 0xFFFFFF) / 16777215; D32 and D32_S8 -> the f32 as is.
pub fn decode_depth(format: DepthFormat, bytes: &[u8], count: usize) -> Result<Vec<f32>> {
    let size = format.depth_copy_texel_size();
    if bytes.len() < count * size {
        bail!(
            "depth read-back holds {} bytes, {} needed for {count} texels of {format}",
            bytes.len(),
            count * size
        );
    }
    let texels = bytes[..count * size].chunks_exact(size);
    let depth = match format {
        DepthFormat::D16 => texels
            .map(|t| (f64::from(u16::from_le_bytes([t[0], t[1]])) / 65535.0) as f32)
            .collect(),
        DepthFormat::X8D24 | DepthFormat::D24S8 => texels
            .map(|t| {
                let v = u32::from_le_bytes([t[0], t[1], t[2], t[3]]) & 0x00FF_FFFF;
                (f64::from(v) / 16_777_215.0) as f32
            })
            .collect(),
        DepthFormat::D32 | DepthFormat::D32S8 => texels
            .map(|t| f32::from_le_bytes([t[0], t[1], t[2], t[3]]))
            .collect(),
    };
    Ok(depth)
}

/// Range and count of the covered pixels (depth different from the clear value).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DepthStats {
    /// Smallest covered depth.
    pub min: Option<f32>,
    /// Largest covered depth.
    pub max: Option<f32>,
    /// Number of covered pixels.
    pub covered: usize,
}

impl DepthStats {
    /// Statistics of the pixels whose depth is not `clear`.
    pub fn of(depth: &[f32], clear: f32) -> DepthStats {
        depth
            .iter()
            .copied()
            .filter(|&d| d != clear)
            .fold(DepthStats::default(), |s, d| DepthStats {
                min: Some(s.min.map_or(d, |m| m.min(d))),
                max: Some(s.max.map_or(d, |m| m.max(d))),
                covered: s.covered + 1,
            })
    }
}

/// The visualisation written to `depth.png` (16-bit greyscale), meant to show the structure
/// of the depth buffer, not its values (those are in `depth.f32`):
/// - a pixel equal to the clear value is black (0);
/// - covered pixels are mapped linearly from [min, max] of the covered pixels' depth to
///   [65535, 8192]: the nearest covered depth is brightest (65535), the farthest is dim
///   (8192), so nothing covered is confused with the background. If every covered pixel has
///   the same depth they are all 65535.
pub fn depth_visualisation(depth: &[f32], clear: f32) -> Vec<u16> {
    const NEAR: f64 = 65535.0;
    const FAR: f64 = 8192.0;
    let stats = DepthStats::of(depth, clear);
    let (Some(min), Some(max)) = (stats.min, stats.max) else {
        return vec![0; depth.len()];
    };
    let (min, max) = (f64::from(min), f64::from(max));
    depth
        .iter()
        .map(|&d| {
            if d == clear {
                0
            } else if max > min {
                let t = (f64::from(d) - min) / (max - min);
                (NEAR + (FAR - NEAR) * t).round() as u16
            } else {
                NEAR as u16
            }
        })
        .collect()
}

/// Contents of `render.json`.
#[derive(Clone, Debug, Serialize)]
pub struct RenderReport {
    /// `VkPhysicalDeviceProperties::deviceName`.
    pub device: String,
    /// `<driverName> <driverInfo>`.
    pub driver: String,
    /// Vulkan name of the depth format, e.g. `D32_SFLOAT`.
    pub depth_format: &'static str,
    /// Scene name, e.g. `overlap`.
    pub scene: &'static str,
    /// How the scene handed its matrices to the vertex shader (`--delivery`): `push`, `ubo`,
    /// `ubo-dynamic` or `ssbo`.
    pub delivery: &'static str,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Counted validation messages (0 without `--validation`).
    pub validation_messages: u32,
    /// The optional device features enabled for the scene (Vulkan names).
    pub features: Vec<&'static str>,
    /// Whether the depth image was read back (false with `--no-depth-readback`).
    pub depth_readback: bool,
    /// Whether the stencil aspect was read back (never: stencil results show in color).
    pub stencil_readback: bool,
    /// The depth of the pixels nothing was drawn on (the scene's first depth clear), from
    /// which covered pixels are told apart.
    pub clear_depth: f32,
    /// Smallest covered depth (null if nothing was covered or depth was not read back).
    pub depth_min: Option<f32>,
    /// Largest covered depth (null if nothing was covered or depth was not read back).
    pub depth_max: Option<f32>,
    /// Pixels whose depth differs from the clear value (null if depth was not read back).
    pub covered_pixels: Option<usize>,
    /// How a multisampled scene was rendered and resolved (null for single-sample scenes).
    pub multisample: Option<MultisampleReport>,
    /// The computed ground truth (null for scenes where something else than the nearest
    /// surface decides what shows).
    pub ground_truth: Option<GroundTruthReport>,
    /// What the tester recorded: its depth images and draws, with the handles a layer above
    /// the driver sees (what a depth profile must count).
    pub recorded: RecordedReport,
}

/// `render.json`'s `recorded` section.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RecordedReport {
    /// Times the scene's commands were recorded and submitted (`--frames`).
    pub frames: u32,
    /// The depth images draws go to.
    pub depth_images: Vec<RecordedImage>,
    /// Draw commands per pipeline and depth image, in one frame.
    pub draws: Vec<RecordedDraws>,
    /// For each object of the scene seen by its camera, the near plane its clip matrix holds
    /// once rounded to float32 (as pushed), computed in f64: -B / k of its depth line over
    /// its w row (-B / (k + 1) for an OpenGL projection); null where the matrix is not a
    /// perspective. What a layer that reads the pushed matrices can recover, exactly.
    pub matrix_near: Vec<Option<f64>>,
}

/// One depth image of `recorded`.
#[derive(Clone, Debug, Serialize)]
pub struct RecordedImage {
    /// `main` (read back), `multisampled` (the main passes' transient attachment, resolved
    /// into `main`) or `shadow` (sampled by later draws).
    pub role: &'static str,
    /// The `VkImage` handle, as `0x...`.
    pub handle: String,
    /// The Vulkan name of its format.
    pub format: String,
    /// `VkImageUsageFlags`.
    pub usage: u32,
    /// Samples per pixel.
    pub samples: u32,
    pub width: u32,
    pub height: u32,
}

/// Draws of one pipeline into one depth image of `recorded`.
#[derive(Clone, Debug, Serialize)]
pub struct RecordedDraws {
    /// The plan's name for the pipeline.
    pub pipeline: &'static str,
    /// The `VkPipeline` handle, as `0x...`.
    pub handle: String,
    /// Its program (`Flat`, `Ubo`, ...).
    pub program: String,
    /// Whether it tests depth.
    pub depth_test: bool,
    /// Its static viewport depth range `[min, max]` (null: dynamic).
    pub viewport_depth: Option<[f32; 2]>,
    /// The role of the depth image (see [`RecordedImage::role`]).
    pub image: &'static str,
    /// Draw commands per frame.
    pub draws: usize,
}

/// `render.json`'s `multisample` section.
#[derive(Clone, Debug, Serialize)]
pub struct MultisampleReport {
    /// Samples per pixel of the multisampled attachments.
    pub samples: u32,
    /// The depth resolve mode (`SAMPLE_ZERO`, `AVERAGE`, `MIN`, `MAX`).
    pub depth_resolve: &'static str,
    /// The stencil resolve mode (`NONE` for formats without stencil, or where the device
    /// resolves depth alone).
    pub stencil_resolve: &'static str,
}

/// The Vulkan name of a single resolve mode (without `VK_RESOLVE_MODE_` and `_BIT`).
pub fn resolve_mode_name(mode: vk::ResolveModeFlags) -> &'static str {
    match mode {
        vk::ResolveModeFlags::NONE => "NONE",
        vk::ResolveModeFlags::SAMPLE_ZERO => "SAMPLE_ZERO",
        vk::ResolveModeFlags::AVERAGE => "AVERAGE",
        vk::ResolveModeFlags::MIN => "MIN",
        vk::ResolveModeFlags::MAX => "MAX",
        _ => "OTHER",
    }
}

/// Writes `color.png`, and `depth.png` and `depth.f32` if depth was read back (`clear`: the
/// depth of uncovered pixels), into `dir`; returns the paths written.
pub fn write_images(dir: &Path, frame: &Frame, clear: f32) -> Result<Vec<PathBuf>> {
    let (w, h) = (frame.width, frame.height);
    let color_path = dir.join("color.png");
    let color = ImageBuffer::<Rgba<u8>, _>::from_raw(w, h, frame.rgba.clone())
        .context("color read-back has the wrong size")?;
    color
        .save_with_format(&color_path, image::ImageFormat::Png)
        .with_context(|| format!("cannot write {}", color_path.display()))?;

    let Some(depth) = &frame.depth else {
        return Ok(vec![color_path]);
    };
    let depth_png_path = dir.join("depth.png");
    let grey = ImageBuffer::<Luma<u16>, _>::from_raw(w, h, depth_visualisation(depth, clear))
        .context("depth read-back has the wrong size")?;
    grey.save_with_format(&depth_png_path, image::ImageFormat::Png)
        .with_context(|| format!("cannot write {}", depth_png_path.display()))?;

    let raw_path = dir.join("depth.f32");
    let raw: Vec<u8> = depth.iter().flat_map(|d| d.to_le_bytes()).collect();
    fs::write(&raw_path, raw).with_context(|| format!("cannot write {}", raw_path.display()))?;

    Ok(vec![color_path, depth_png_path, raw_path])
}

/// Writes `render.json` into `dir`; returns its path.
pub fn write_report(dir: &Path, report: &RenderReport) -> Result<PathBuf> {
    let path = dir.join("render.json");
    let mut json = serde_json::to_string_pretty(report).context("cannot serialise render.json")?;
    json.push('\n');
    fs::write(&path, json).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_every_format() {
        let d16 = decode_depth(DepthFormat::D16, &[0xFF, 0xFF, 0x00, 0x80], 2).unwrap();
        assert_eq!(d16, vec![1.0, (32768.0f64 / 65535.0) as f32]);

        // The top byte (X8 / stencil) is ignored.
        let word = |v: u32| v.to_le_bytes();
        let bytes: Vec<u8> = [word(0xAB00_0000), word(0x12FF_FFFF), word(0x0080_0000)].concat();
        for format in [DepthFormat::X8D24, DepthFormat::D24S8] {
            let d = decode_depth(format, &bytes, 3).unwrap();
            assert_eq!(d, vec![0.0, 1.0, (8_388_608.0f64 / 16_777_215.0) as f32]);
        }

        let bytes: Vec<u8> = [0.25f32, 1.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        for format in [DepthFormat::D32, DepthFormat::D32S8] {
            assert_eq!(decode_depth(format, &bytes, 2).unwrap(), vec![0.25, 1.0]);
        }

        assert!(decode_depth(DepthFormat::D32, &bytes, 3).is_err());
    }

    #[test]
    fn stats_skip_clear_pixels() {
        let stats = DepthStats::of(&[1.0, 0.5, 0.25, 1.0, 0.75], 1.0);
        assert_eq!(stats.min, Some(0.25));
        assert_eq!(stats.max, Some(0.75));
        assert_eq!(stats.covered, 3);
        assert_eq!(DepthStats::of(&[1.0, 1.0], 1.0).covered, 0);
    }

    #[test]
    fn visualisation_maps_near_bright_far_dim_clear_black() {
        let grey = depth_visualisation(&[1.0, 0.2, 0.6, 0.4], 1.0);
        assert_eq!(grey[0], 0);
        assert_eq!(grey[1], 65535);
        assert_eq!(grey[2], 8192);
        assert!(grey[3] > 8192 && grey[3] < 65535);
        assert_eq!(depth_visualisation(&[1.0, 0.3], 1.0), vec![0, 65535]);
        assert_eq!(depth_visualisation(&[1.0], 1.0), vec![0]);
    }
}
