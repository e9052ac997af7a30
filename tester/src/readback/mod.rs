//! Getting the rendered images back and writing them out: the host-visible read-back buffers,
//! the barriers and copies recorded after the render pass, decoding of the depth aspect to
//! f32 for every depth format, and the output files (`color.png`, `depth.png`, `depth.f32`,
//! `render.json`; the ground-truth files are written by `main.rs`). A render of several views
//! (multiview) reads back each view's array layer, and writes view n's files into `view<n>/`
//! ([`view_dir`]). With `--no-depth-readback` only the color image is read back (the depth
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
use crate::target::{full_range, Attachment, BoundImage, DepthFormat, Targets};

/// How the depth aspect reaches the host (`--depth-route`): the copies an application makes
/// of a depth image, for revz's conversion of copies (issue #21). Every route must deliver
/// the same values.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DepthRoute {
    /// `vkCmdCopyImageToBuffer` into the host buffer.
    #[default]
    Direct,
    /// `vkCmdCopyImage` into a second depth image (DEPTH_STENCIL_ATTACHMENT | TRANSFER_SRC |
    /// TRANSFER_DST, which revz reverses by default: the copy goes down as it is), then into
    /// the host buffer. The second images of the routes below that name no other usage have
    /// these too.
    Image,
    /// The same through a second image that shaders read as an input attachment
    /// (INPUT_ATTACHMENT too). Until session 24 revz kept it native, and the copy crossed
    /// conventions; now it is reversed (its input reads converted in the shader), and in
    /// `infinite` mode it stores complementary depth, so the copy crosses maps there (n / w
    /// into 1 - D). lavapipe has no storage or linear depth images, the usages that still
    /// keep an attachment native.
    NativeImage,
    /// `vkCmdCopyImage` into a second depth image with transfer usage only, which revz keeps
    /// native and in its format (no depth attachment, issue #44): the copy into it converts.
    TransferImage,
    /// `vkCmdCopyImageToBuffer` into a device buffer, `vkCmdCopyBufferToImage` into a second
    /// depth image, then into the host buffer: a round trip through the application's bytes.
    Buffer,
    /// `vkCmdBlitImage` (same size, NEAREST, mirrored in x and back by the read: the blit
    /// flips x, a second blit would not be a copy, so the host flips the rows back) into a
    /// second image that shaders read as an input attachment (see `NativeImage`), then into
    /// the host buffer.
    BlitNativeImage,
    /// `vkCmdCopyImage` of the depth aspect into a second image created with
    /// `VK_IMAGE_CREATE_ALIAS_BIT`, whose memory the application places by its format's sizes
    /// (revz keeps its D16/D24 format where it promotes the first), then into the host buffer.
    UnormImage,
    /// The mirrored blit of `blit-native-image` of the depth aspect into such an image.
    BlitUnormImage,
    /// `vkCmdCopyImage` into slice 1 of a 3D depth image two slices deep (TRANSFER_SRC |
    /// TRANSFER_DST: no depth attachment, so native and in its format; the copy converts into
    /// the slice), then that slice into the host buffer (issue #44: copies of 3D depth images).
    Volume,
    /// The same copy into both slices of the 3D image, then the mirrored blit of its whole
    /// box, both slices at once, into a second 3D image created with
    /// `VK_IMAGE_CREATE_ALIAS_BIT`, and that image's slice 1 into the host buffer: a blit whose
    /// source box is several slices deep (both native: it goes down as it is; with
    /// `REVZ_REVERSE_OBSERVABLE=all` both are reversed and the first promoted, and it converts
    /// through a 3D staged image).
    BlitUnormVolume,
}

impl DepthRoute {
    /// The second image's usage and flags, if the route has one.
    fn second_image(self) -> Option<(vk::ImageUsageFlags, vk::ImageCreateFlags)> {
        let transfer = vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
        let copied = transfer | vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
        let none = vk::ImageCreateFlags::empty();
        match self {
            DepthRoute::Direct | DepthRoute::Volume | DepthRoute::BlitUnormVolume => None,
            DepthRoute::TransferImage => Some((transfer, none)),
            DepthRoute::Image | DepthRoute::Buffer => Some((copied, none)),
            DepthRoute::NativeImage | DepthRoute::BlitNativeImage => {
                Some((copied | vk::ImageUsageFlags::INPUT_ATTACHMENT, none))
            }
            DepthRoute::UnormImage | DepthRoute::BlitUnormImage => {
                Some((copied, vk::ImageCreateFlags::ALIAS))
            }
        }
    }

    /// Whether the route blits (mirrored).
    fn blits(self) -> bool {
        matches!(
            self,
            DepthRoute::BlitNativeImage | DepthRoute::BlitUnormImage | DepthRoute::BlitUnormVolume
        )
    }

    /// The 3D images of the route (their create flags), if it has them: the one the depth is
    /// copied into first, then the one it is blitted into.
    fn volumes(self) -> &'static [vk::ImageCreateFlags] {
        const PLAIN: vk::ImageCreateFlags = vk::ImageCreateFlags::empty();
        match self {
            DepthRoute::Volume => &[PLAIN],
            DepthRoute::BlitUnormVolume => &[PLAIN, vk::ImageCreateFlags::ALIAS],
            _ => &[],
        }
    }
}

/// The slices of the routes' 3D images (TRANSFER_SRC | TRANSFER_DST, no view).
const VOLUME_SLICES: u32 = 2;

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
    /// The image-to-image copies of the `image` and `native-image` routes name every aspect
    /// of a depth-stencil format (the stencil too), as applications copying a whole
    /// depth-stencil image do; the depth aspect alone otherwise.
    pub all_aspects: bool,
}

/// What the host buffer's row padding holds before and after the render.
pub const PADDING_BYTE: u8 = 0xA5;

/// Host-visible buffers receiving the color image and the depth aspect of the depth image:
/// of each view's array layer where a multiview pass rendered several
/// ([`Targets::views`]; only the direct route reads those back).
#[derive(Debug)]
pub struct Readback<'a> {
    /// One per view, layer 0 first.
    color: Vec<HostBuffer<'a>>,
    /// One per view, layer 0 first; empty with `--no-depth-readback`.
    depth: Vec<HostBuffer<'a>>,
    extent: vk::Extent2D,
    depth_format: DepthFormat,
    options: DepthReadback,
    /// The route's second depth image.
    second: Option<Attachment<'a>>,
    /// The route's 3D images ([`DepthRoute::volumes`]).
    volumes: Vec<BoundImage<'a>>,
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
    /// Creates the read-back buffers for `targets`, one set per view (none for depth unless
    /// `depth`). The routes through other images copy one layer: a render of several views
    /// takes the direct route.
    pub fn new(
        gpu: &'a Gpu,
        targets: &Targets<'_>,
        depth: bool,
        options: DepthReadback,
    ) -> Result<Self> {
        let views = targets.views();
        if depth && views > 1 && options.route != DepthRoute::Direct {
            bail!(
                "{views} views are read back by the direct depth route only, not {:?}",
                options.route
            );
        }
        let pixels = targets.pixel_count();
        let color = (0..views)
            .map(|_| {
                HostBuffer::new(gpu, pixels * 4, vk::BufferUsageFlags::TRANSFER_DST)
                    .context("color read-back buffer")
            })
            .collect::<Result<_>>()?;
        let texel = targets.depth_format.depth_copy_texel_size();
        let extent = targets.extent;
        let padded = (extent.width + options.row_padding) as usize * extent.height as usize;
        let (mut depth_buffers, mut second, mut staging) = (Vec::new(), None, None);
        let mut volumes = Vec::new();
        if depth {
            for _ in 0..views {
                let mut buffer =
                    HostBuffer::new(gpu, padded * texel, vk::BufferUsageFlags::TRANSFER_DST)
                        .context("depth read-back buffer")?;
                buffer.write(&vec![PADDING_BYTE; padded * texel]);
                depth_buffers.push(buffer);
            }
            if let Some((usage, flags)) = options.route.second_image() {
                let format = targets.depth_format;
                second = Some(
                    Attachment::copied_with_flags(gpu, format.vk_format(), usage, flags, extent)
                        .context("the depth route's second image")?,
                );
            }
            for &flags in options.route.volumes() {
                let format = targets.depth_format.vk_format();
                let transfer =
                    vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
                let deep = vk::Extent3D {
                    width: extent.width,
                    height: extent.height,
                    depth: VOLUME_SLICES,
                };
                volumes.push(
                    BoundImage::new(gpu, format, (transfer, flags), deep)
                        .context("the depth route's 3D image")?,
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
            depth: depth_buffers,
            extent,
            depth_format: targets.depth_format,
            options,
            second,
            volumes,
            staging,
        })
    }

    /// Records, after the render pass: attachment layouts -> TRANSFER_SRC_OPTIMAL (waiting for
    /// the attachment writes, including the store ops and resolves), the copies of the color image and of
    /// the DEPTH aspect (if read back), each view's layer into its buffers, and a TRANSFER ->
    /// HOST barrier so the host can read the buffers once the submission's fence has signalled.
    pub fn record(&self, device: &ash::Device, cmd: vk::CommandBuffer, targets: &Targets<'_>) {
        // The layers read back: each view's.
        let layers = |aspects| vk::ImageSubresourceRange {
            layer_count: targets.views(),
            ..full_range(aspects)
        };
        let mut to_transfer = vec![vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::COLOR_ATTACHMENT_WRITE)
            .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
            .old_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(targets.color.image)
            .subresource_range(layers(vk::ImageAspectFlags::COLOR))];
        if !self.depth.is_empty() {
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
                    .subresource_range(layers(targets.depth_format.aspects())),
            );
        }
        // The route's second image and 3D images: written first, by a copy or a blit.
        let routed = self.second.iter().map(|second| second.image);
        for image in routed.chain(self.volumes.iter().map(|volume| volume.image)) {
            to_transfer.push(
                vk::ImageMemoryBarrier::default()
                    .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .old_layout(vk::ImageLayout::UNDEFINED)
                    .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(image)
                    .subresource_range(full_range(targets.depth_format.aspects())),
            );
        }
        let to_host: Vec<vk::BufferMemoryBarrier<'_>> = self
            .color
            .iter()
            .chain(&self.depth)
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
            for (layer, color) in (0..).zip(&self.color) {
                device.cmd_copy_image_to_buffer(
                    cmd,
                    targets.color.image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    color.buffer,
                    &[self.layer_region(vk::ImageAspectFlags::COLOR, 0, layer)],
                );
            }
        }
        for (layer, depth) in (0..).zip(&self.depth) {
            self.record_depth(device, cmd, targets.depth.image, depth.buffer, layer);
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
        self.layer_region(aspect, row_length, 0)
    }

    /// [`Self::region`] of array layer `layer`.
    fn layer_region(
        &self,
        aspect: vk::ImageAspectFlags,
        row_length: u32,
        layer: u32,
    ) -> vk::BufferImageCopy {
        vk::BufferImageCopy {
            buffer_offset: 0,
            buffer_row_length: row_length,
            buffer_image_height: 0,
            image_subresource: vk::ImageSubresourceLayers {
                aspect_mask: aspect,
                mip_level: 0,
                base_array_layer: layer,
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

    /// The depth aspect's copies of array layer `layer` along the route, into `host` (the
    /// depth image is in TRANSFER_SRC_OPTIMAL, the second image in TRANSFER_DST_OPTIMAL; the
    /// routes through other images copy layer 0, the only one read back where they are
    /// taken).
    fn record_depth(
        &self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        image: vk::Image,
        host: vk::Buffer,
        layer: u32,
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
        if !self.volumes.is_empty() {
            self.record_volumes(&copies, image, host, padded);
            return;
        }
        let Some(second) = &self.second else {
            copies.image_to_buffer(image, host, self.layer_region(depth, padded, layer));
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
            DepthRoute::BlitNativeImage | DepthRoute::BlitUnormImage => {
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
            _ => {
                let layers = if self.options.all_aspects {
                    vk::ImageSubresourceLayers {
                        aspect_mask: self.depth_format.aspects(),
                        ..layers
                    }
                } else {
                    layers
                };
                copies.image_to_image(
                    image,
                    second.image,
                    vk::ImageCopy {
                        src_subresource: layers,
                        src_offset: vk::Offset3D::default(),
                        dst_subresource: layers,
                        dst_offset: vk::Offset3D::default(),
                        extent: self.region(depth, 0).image_extent,
                    },
                )
            }
        }
        copies.barrier(
            vk::BufferMemoryBarrier::default(),
            Some(self.written_to_read(second.image)),
        );
        copies.image_to_buffer(second.image, host, self.region(depth, padded));
    }

    /// The barrier of a route's image written by a transfer (TRANSFER_DST_OPTIMAL) and read by
    /// the next (TRANSFER_SRC_OPTIMAL), every aspect.
    fn written_to_read(&self, image: vk::Image) -> vk::ImageMemoryBarrier<'static> {
        vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(full_range(self.depth_format.aspects()))
    }

    /// The 3D routes: the depth aspect of `image` into slice 1 of the first 3D image (both
    /// slices for `blit-unorm-volume`, which then blits them into the second, mirrored), and
    /// slice 1 of the last 3D image into `host` with `padded` texels a row.
    fn record_volumes(&self, copies: &Copies<'_>, image: vk::Image, host: vk::Buffer, padded: u32) {
        let depth = vk::ImageAspectFlags::DEPTH;
        let layers = self.region(depth, 0).image_subresource;
        let into_slice = |z| vk::ImageCopy {
            src_subresource: layers,
            src_offset: vk::Offset3D::default(),
            dst_subresource: layers,
            dst_offset: vk::Offset3D { x: 0, y: 0, z },
            extent: self.region(depth, 0).image_extent,
        };
        let written = |volume: &BoundImage<'_>| self.written_to_read(volume.image);
        let first = &self.volumes[0];
        let slices: &[i32] = if self.volumes.len() > 1 {
            &[0, 1]
        } else {
            &[1]
        };
        for &z in slices {
            copies.image_to_image(image, first.image, into_slice(z));
        }
        copies.barrier(vk::BufferMemoryBarrier::default(), Some(written(first)));
        let last = self.volumes.last().expect("a 3D route has a 3D image");
        if let Some(second) = self.volumes.get(1) {
            let (w, h, d) = (
                self.extent.width as i32,
                self.extent.height as i32,
                VOLUME_SLICES as i32,
            );
            let corner = |x, y, z| vk::Offset3D { x, y, z };
            copies.blit(
                first.image,
                second.image,
                vk::ImageBlit {
                    src_subresource: layers,
                    src_offsets: [corner(w, 0, 0), corner(0, h, d)],
                    dst_subresource: layers,
                    dst_offsets: [corner(0, 0, 0), corner(w, h, d)],
                },
            );
            copies.barrier(vk::BufferMemoryBarrier::default(), Some(written(second)));
        }
        let mut region = self.region(depth, padded);
        region.image_offset.z = 1;
        copies.image_to_buffer(last.image, host, region);
    }

    /// The read-back contents of view 0 (call only after the render's fence has signalled).
    pub fn frame(&self) -> Result<Frame> {
        self.view_frame(0)
    }

    /// The read-back contents of every view, view 0 first (as [`Self::frame`]).
    pub fn frames(&self) -> Result<Vec<Frame>> {
        (0..self.color.len())
            .map(|view| self.view_frame(view))
            .collect()
    }

    fn view_frame(&self, view: usize) -> Result<Frame> {
        let pixels = self.extent.width as usize * self.extent.height as usize;
        let rgba = self.color[view].contents()[..pixels * 4].to_vec();
        let depth = match self.depth.get(view) {
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
        if !self.options.route.blits() {
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

mod output;

pub use output::*;

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
