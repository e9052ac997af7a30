//! `revz-tester transfers`: depth images that are only ever copied, as a conformance suite's
//! copy and blit groups use them (issue #44). Two images with TRANSFER_SRC | TRANSFER_DST
//! usage and no other, which revz keeps native. `--attachment` adds DEPTH_STENCIL_ATTACHMENT
//! to the 2D ones, which revz then reverses (and stores D16/D24 as float32 in the precise
//! modes); `REVZ_REVERSE_OBSERVABLE=all` reverses every image. The source is uploaded from a
//! buffer (depth values of full mantissas, a stencil pattern), the destination with depth 1
//! and stencil 255; then one copy or blit of every aspect the format has (2D and 3D images,
//! boxes downscaled, mirrored and 1:1, or with each aspect's layout set apart under
//! `separateDepthStencilLayouts`); then the whole destination is read back into a buffer.
//!
//! Writes `depth.f32` (the destination's depth, decoded), `stencil.u8` (its stencil, for
//! stencil formats), `aspects.u8` (per texel, the aspects the regions write: bit 0 depth, bit 1
//! stencil) and `transfers.json`; exits 2 on validation messages. `tests/tests/transfers.rs`
//! compares the files with and without revz.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use ash::vk;
use serde::Serialize;

use crate::gpu::{Features, Gpu, GpuOptions, HostBuffer};
use crate::readback::decode_depth;
use crate::target::{BoundImage, DepthFormat};

/// What is copied, and how.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransferCase {
    /// 2D 64x64 into 2D 64x64, one `vkCmdBlitImage` (NEAREST) of regions of each aspect
    /// (depth, stencil, both): the whole source downscaled into 16x16, the same mirrored in x
    /// and y, and an 8x8 block 1:1; layouts TRANSFER_SRC_OPTIMAL and TRANSFER_DST_OPTIMAL.
    Blit,
    /// `blit` with each aspect of the depth/stencil images transitioned and uploaded apart
    /// (`separateDepthStencilLayouts`): the depth's barrier and upload, then the stencil's
    /// barrier from UNDEFINED and its upload. Stencil formats only.
    BlitSeparateLayouts,
    /// 3D 16x16x16 into 3D 16x16x16, `vkCmdCopyImage`: a 4x4x4 box to (i, 12 - i, i) for i =
    /// 0, 4, 8, 12, of each aspect.
    #[value(name = "copy-3d")]
    Copy3d,
    /// 3D 16x16x16 into 2D 64x64 (`VK_KHR_maintenance1`): the sixteen slices side by side.
    #[value(name = "copy-3d-to-2d")]
    Copy3dTo2d,
    /// 3D 16x16x16 into 3D 16x16x16, one blit: the whole source downscaled into 4x4x4 boxes
    /// (one per aspect, the depth one mirrored in z), and 4x4x4 depth boxes 1:1 at z = 0, 4, 8,
    /// 12.
    #[value(name = "blit-3d")]
    Blit3d,
    /// 3D 16x16x16 into 2D 64x64, one blit: the whole source squeezed into one slice (a box
    /// sixteen slices deep into one, mirrored in z for depth), one per aspect, and slices 0, 5,
    /// 10 and 15 of the depth 1:1.
    #[value(name = "blit-3d-to-2d")]
    Blit3dTo2d,
    /// `copy-3d-to-2d` of the stencil aspect alone (stencil formats only): with
    /// `--attachment` in the precise modes, between a 3D image that keeps D24_S8 and a 2D one
    /// stored as D32_S8, which cannot go down as it is.
    #[value(name = "copy-stencil-3d-to-2d")]
    CopyStencil3dTo2d,
    /// `blit-3d-to-2d` of the stencil aspect alone (stencil formats only).
    #[value(name = "blit-stencil-3d-to-2d")]
    BlitStencil3dTo2d,
}

impl TransferCase {
    fn name(self) -> &'static str {
        match self {
            TransferCase::Blit => "blit",
            TransferCase::BlitSeparateLayouts => "blit-separate-layouts",
            TransferCase::Copy3d => "copy-3d",
            TransferCase::Copy3dTo2d => "copy-3d-to-2d",
            TransferCase::Blit3d => "blit-3d",
            TransferCase::Blit3dTo2d => "blit-3d-to-2d",
            TransferCase::CopyStencil3dTo2d => "copy-stencil-3d-to-2d",
            TransferCase::BlitStencil3dTo2d => "blit-stencil-3d-to-2d",
        }
    }

    /// The source's and the destination's extents (a depth above 1: a 3D image).
    fn extents(self) -> (vk::Extent3D, vk::Extent3D) {
        let square = vk::Extent3D {
            width: 64,
            height: 64,
            depth: 1,
        };
        let cube = vk::Extent3D {
            width: 16,
            height: 16,
            depth: 16,
        };
        match self {
            TransferCase::Blit | TransferCase::BlitSeparateLayouts => (square, square),
            TransferCase::Copy3d | TransferCase::Blit3d => (cube, cube),
            TransferCase::Copy3dTo2d
            | TransferCase::Blit3dTo2d
            | TransferCase::CopyStencil3dTo2d
            | TransferCase::BlitStencil3dTo2d => (cube, square),
        }
    }
}

/// `revz-tester transfers`.
#[derive(Debug, clap::Args)]
pub struct TransferArgs {
    /// Run on the first device whose name contains NAME (default: lavapipe where present).
    #[arg(long, value_name = "NAME")]
    device: Option<String>,
    /// The images' format.
    #[arg(long, value_enum, value_name = "FORMAT", default_value = "d32")]
    depth_format: DepthFormat,
    /// What is copied.
    #[arg(long = "case", value_enum)]
    case: TransferCase,
    /// Enable the Khronos validation layer (exit status 2 when it reports anything).
    #[arg(long)]
    validation: bool,
    /// With `--validation`: synchronization validation too.
    #[arg(long)]
    sync_validation: bool,
    /// Give the 2D images DEPTH_STENCIL_ATTACHMENT usage too (3D images keep transfer usage
    /// only): revz then reverses them (and promotes D16/D24 storage in the precise modes),
    /// where it keeps images that are no attachment native.
    #[arg(long)]
    attachment: bool,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

/// `transfers.json`.
#[derive(Debug, Serialize)]
struct TransferReport {
    device: String,
    driver: String,
    depth_format: &'static str,
    case: &'static str,
    texels: usize,
    attachment: bool,
    validation_messages: u32,
}

/// Runs one case; exit status 0, or 2 with validation messages.
pub fn run(args: &TransferArgs) -> Result<std::process::ExitCode> {
    let format = args.depth_format;
    let case = args.case;
    let stencil_only = matches!(
        case,
        TransferCase::BlitSeparateLayouts
            | TransferCase::CopyStencil3dTo2d
            | TransferCase::BlitStencil3dTo2d
    );
    if stencil_only && !format.has_stencil() {
        bail!(
            "case {} needs a depth format with a stencil aspect (d24-s8 or d32-s8)",
            case.name()
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let gpu = Gpu::new(&GpuOptions {
        device: args.device.clone(),
        validation: args.validation,
        sync_validation: args.sync_validation,
        max_api_version: None,
        features: Features {
            separate_depth_stencil_layouts: case == TransferCase::BlitSeparateLayouts,
            ..Features::default()
        },
    })?;
    if case == TransferCase::BlitSeparateLayouts && !gpu.enabled.separate_depth_stencil_layouts {
        bail!("the device lacks separateDepthStencilLayouts");
    }
    let (depth, stencil, aspects) = {
        let transfer = Transfer::new(&gpu, format, case, args.attachment)?;
        let (depth, stencil) = transfer.run()?;
        (depth, stencil, transfer.written_aspects())
    };
    let texels = depth.len();
    let info = gpu.info.clone();
    let log = gpu.validation_log();
    drop(gpu);
    let messages = log.count();
    let out = &args.out;
    let bytes: Vec<u8> = depth.iter().flat_map(|d| d.to_le_bytes()).collect();
    std::fs::write(out.join("depth.f32"), bytes).context("writing depth.f32")?;
    if let Some(stencil) = &stencil {
        std::fs::write(out.join("stencil.u8"), stencil).context("writing stencil.u8")?;
    }
    std::fs::write(out.join("aspects.u8"), aspects).context("writing aspects.u8")?;
    let report = TransferReport {
        device: info.name.clone(),
        driver: info.driver(),
        depth_format: format.vk_name(),
        case: case.name(),
        texels,
        attachment: args.attachment,
        validation_messages: messages,
    };
    std::fs::write(
        out.join("transfers.json"),
        serde_json::to_string_pretty(&report)?,
    )
    .context("writing transfers.json")?;
    if messages > 0 {
        eprintln!("revz-tester: {messages} validation message(s) reported");
        return Ok(std::process::ExitCode::from(2));
    }
    Ok(std::process::ExitCode::SUCCESS)
}

/// A region of the whole image's `aspect`, tightly packed in a buffer.
fn whole(image: &BoundImage<'_>, aspect: vk::ImageAspectFlags) -> vk::BufferImageCopy {
    vk::BufferImageCopy {
        image_subresource: layers(aspect),
        image_extent: image.extent,
        ..Default::default()
    }
}

/// A case's image: 3D where `extent` is deeper than 1, else 2D, with transfer usage and, for
/// a 2D one where `attachment`, DEPTH_STENCIL_ATTACHMENT usage too.
fn image<'a>(
    gpu: &'a Gpu,
    format: vk::Format,
    extent: vk::Extent3D,
    attachment: bool,
) -> Result<BoundImage<'a>> {
    let mut usage = vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
    if attachment && extent.depth == 1 {
        usage |= vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
    }
    BoundImage::new(gpu, format, (usage, vk::ImageCreateFlags::empty()), extent)
}

fn layers(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceLayers {
    vk::ImageSubresourceLayers {
        aspect_mask: aspect,
        mip_level: 0,
        base_array_layer: 0,
        layer_count: 1,
    }
}

fn offset(x: i32, y: i32, z: i32) -> vk::Offset3D {
    vk::Offset3D { x, y, z }
}

/// The source's depth texels: a hash of the texel's index, in the buffer layout of `format`'s
/// depth aspect; for float formats values of full mantissas in [2^-12, 1) (every bit of a
/// float32 in use, where a flip to 1 - d and back would lose the low ones), for UNORM formats
/// every integer equally likely.
fn depth_texels(format: DepthFormat, count: usize) -> Vec<u8> {
    let value = |i: usize| {
        let hashed = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        match format {
            DepthFormat::D32 | DepthFormat::D32S8 => {
                let mantissa = (hashed >> 41) as u32 & 0x7F_FFFF;
                let exponent = 126 - (hashed >> 20) as u32 % 12;
                f64::from(f32::from_bits(exponent << 23 | mantissa))
            }
            _ => (hashed >> 40) as f64 / f64::from(1u32 << 24),
        }
    };
    (0..count)
        .flat_map(|i| texel_bytes(format, value(i)))
        .collect()
}

/// One texel of depth `d` as a copy of `format`'s depth aspect lays it out.
fn texel_bytes(format: DepthFormat, d: f64) -> Vec<u8> {
    match format {
        DepthFormat::D16 => ((d * 65535.0).round() as u16).to_le_bytes().to_vec(),
        DepthFormat::X8D24 | DepthFormat::D24S8 => {
            ((d * 16_777_215.0).round() as u32).to_le_bytes().to_vec()
        }
        DepthFormat::D32 | DepthFormat::D32S8 => (d as f32).to_le_bytes().to_vec(),
    }
}

/// A case's blits or copies (one of the two is empty).
struct Regions {
    blits: Vec<vk::ImageBlit>,
    copies: Vec<vk::ImageCopy>,
}

/// The two images, their upload and read-back buffers, a command pool and a fence.
struct Transfer<'a> {
    gpu: &'a Gpu,
    format: DepthFormat,
    case: TransferCase,
    source: BoundImage<'a>,
    destination: BoundImage<'a>,
    /// Uploads: source depth, source stencil, destination depth, destination stencil.
    uploads: [HostBuffer<'a>; 4],
    depth_out: HostBuffer<'a>,
    stencil_out: HostBuffer<'a>,
}

impl<'a> Transfer<'a> {
    fn new(
        gpu: &'a Gpu,
        format: DepthFormat,
        case: TransferCase,
        attachment: bool,
    ) -> Result<Self> {
        let (from, to) = case.extents();
        let source = image(gpu, format.vk_format(), from, attachment)?;
        let destination = image(gpu, format.vk_format(), to, attachment)?;
        let (n, m) = (source.texels(), destination.texels());
        let texel = format.depth_copy_texel_size();
        let upload = |bytes: &[u8]| -> Result<HostBuffer<'a>> {
            let mut buffer = HostBuffer::new(gpu, bytes.len(), vk::BufferUsageFlags::TRANSFER_SRC)?;
            buffer.write(bytes);
            Ok(buffer)
        };
        let stencil: Vec<u8> = (0..n).map(|i| (i * 37 % 251) as u8).collect();
        let uploads = [
            upload(&depth_texels(format, n))?,
            upload(&stencil)?,
            upload(&texel_bytes(format, 1.0).repeat(m))?,
            upload(&vec![255u8; m])?,
        ];
        let out = |size| HostBuffer::new(gpu, size, vk::BufferUsageFlags::TRANSFER_DST);
        Ok(Transfer {
            gpu,
            format,
            case,
            source,
            destination,
            uploads,
            depth_out: out(m * texel)?,
            stencil_out: out(m)?,
        })
    }

    /// The aspects copied: depth, and stencil where the format has it.
    fn aspects(&self) -> Vec<vk::ImageAspectFlags> {
        let mut aspects = vec![vk::ImageAspectFlags::DEPTH];
        if self.format.has_stencil() {
            aspects.push(vk::ImageAspectFlags::STENCIL);
        }
        aspects
    }

    /// Records and submits the case; the destination's decoded depth and its stencil.
    fn run(&self) -> Result<(Vec<f32>, Option<Vec<u8>>)> {
        let device = &self.gpu.device;
        let pool_info =
            vk::CommandPoolCreateInfo::default().queue_family_index(self.gpu.queue_family);
        // SAFETY: a valid device and create info.
        let pool = unsafe { device.create_command_pool(&pool_info, None) }
            .context("vkCreateCommandPool failed")?;
        let result = self.record_and_submit(pool);
        // SAFETY: the submission finished (or never started); the pool is this device's.
        unsafe { device.destroy_command_pool(pool, None) };
        result?;
        let m = self.destination.texels();
        let depth = decode_depth(
            self.format,
            &self.depth_out.contents()[..m * self.format.depth_copy_texel_size()],
            m,
        )?;
        let stencil = self
            .format
            .has_stencil()
            .then(|| self.stencil_out.contents()[..m].to_vec());
        Ok((depth, stencil))
    }

    fn record_and_submit(&self, pool: vk::CommandPool) -> Result<()> {
        let device = &self.gpu.device;
        let allocate = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: a valid pool of this device.
        let cmd = unsafe { device.allocate_command_buffers(&allocate) }
            .context("vkAllocateCommandBuffers failed")?[0];
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: a fresh command buffer.
        unsafe { device.begin_command_buffer(cmd, &begin) }
            .context("vkBeginCommandBuffer failed")?;
        self.record(cmd);
        // SAFETY: the command buffer is recording.
        unsafe { device.end_command_buffer(cmd) }.context("vkEndCommandBuffer failed")?;
        let fence_info = vk::FenceCreateInfo::default();
        // SAFETY: a valid device.
        let fence =
            unsafe { device.create_fence(&fence_info, None) }.context("vkCreateFence failed")?;
        let buffers = [cmd];
        let submit = vk::SubmitInfo::default().command_buffers(&buffers);
        // SAFETY: an executable command buffer, an unsignalled fence, this device's queue.
        let submitted = unsafe { device.queue_submit(self.gpu.queue, &[submit], fence) }
            .context("vkQueueSubmit failed")
            .and_then(|()| {
                // SAFETY: the fence was submitted.
                unsafe { device.wait_for_fences(&[fence], true, 60_000_000_000) }
                    .context("vkWaitForFences failed")
            });
        // SAFETY: the fence is no longer in use (waited on, or never submitted).
        unsafe { device.destroy_fence(fence, None) };
        submitted
    }

    /// A TRANSFER -> TRANSFER barrier of `aspects` of `image` from `old` to `new`.
    fn transition(
        &self,
        cmd: vk::CommandBuffer,
        image: vk::Image,
        aspects: vk::ImageAspectFlags,
        (old, new): (vk::ImageLayout, vk::ImageLayout),
    ) {
        let barrier = vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::TRANSFER_READ | vk::AccessFlags::TRANSFER_WRITE)
            .old_layout(old)
            .new_layout(new)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(vk::ImageSubresourceRange {
                aspect_mask: aspects,
                base_mip_level: 0,
                level_count: 1,
                base_array_layer: 0,
                layer_count: 1,
            });
        // SAFETY: a recording command buffer outside a render pass; a valid image.
        unsafe {
            self.gpu.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[barrier],
            )
        }
    }

    fn record(&self, cmd: vk::CommandBuffer) {
        let device = &self.gpu.device;
        let all = self.format.aspects();
        let dst_layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
        let undefined = vk::ImageLayout::UNDEFINED;
        let images = [
            (&self.source, &self.uploads[0], &self.uploads[1]),
            (&self.destination, &self.uploads[2], &self.uploads[3]),
        ];
        for (image, depth, stencil) in images {
            let upload = |buffer: &HostBuffer<'_>, aspect| {
                // SAFETY: the image is in TRANSFER_DST_OPTIMAL for `aspect`, the buffer holds
                // every texel.
                unsafe {
                    device.cmd_copy_buffer_to_image(
                        cmd,
                        buffer.buffer,
                        image.image,
                        dst_layout,
                        &[whole(image, aspect)],
                    )
                }
            };
            // With separate layouts each aspect's layout is set apart: the stencil leaves
            // UNDEFINED after the depth is written, as an application uploading the aspects in
            // turn does.
            let apart = self.case == TransferCase::BlitSeparateLayouts;
            if !apart {
                self.transition(cmd, image.image, all, (undefined, dst_layout));
            }
            for aspect in self.aspects() {
                if apart {
                    self.transition(cmd, image.image, aspect, (undefined, dst_layout));
                }
                let data = if aspect == vk::ImageAspectFlags::DEPTH {
                    depth
                } else {
                    stencil
                };
                upload(data, aspect);
            }
        }
        // The GENERAL layout, which a conformance suite also copies in, draws the validation
        // layer's performance warnings: the optimal layouts only.
        let (src_layout, dst_copy_layout) = (
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        );
        self.transition(cmd, self.source.image, all, (dst_layout, src_layout));
        self.transition(
            cmd,
            self.destination.image,
            all,
            (dst_layout, dst_copy_layout),
        );
        self.record_case(cmd, src_layout, dst_copy_layout);
        let read_layout = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
        self.transition(
            cmd,
            self.destination.image,
            all,
            (dst_copy_layout, read_layout),
        );
        let outs = [&self.depth_out, &self.stencil_out];
        for (aspect, out) in self.aspects().into_iter().zip(outs) {
            // SAFETY: the destination is in TRANSFER_SRC_OPTIMAL, the buffer holds it.
            unsafe {
                device.cmd_copy_image_to_buffer(
                    cmd,
                    self.destination.image,
                    read_layout,
                    out.buffer,
                    &[whole(&self.destination, aspect)],
                )
            };
        }
        let to_host = vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::HOST_READ);
        // SAFETY: a recording command buffer.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &[to_host],
                &[],
                &[],
            )
        }
    }

    /// The case's regions: every aspect the format has, one set of regions each (depth,
    /// stencil, both, for blits; depth and stencil for copies).
    fn regions(&self) -> Regions {
        let depth = vk::ImageAspectFlags::DEPTH;
        let stencil_alone = matches!(
            self.case,
            TransferCase::CopyStencil3dTo2d | TransferCase::BlitStencil3dTo2d
        );
        let mut aspect_sets = vec![depth];
        if stencil_alone {
            aspect_sets = vec![vk::ImageAspectFlags::STENCIL];
        } else if self.format.has_stencil() {
            aspect_sets.push(vk::ImageAspectFlags::STENCIL);
            aspect_sets.push(depth | vk::ImageAspectFlags::STENCIL);
        }
        let blit = |from: [vk::Offset3D; 2], to: [vk::Offset3D; 2], aspects| vk::ImageBlit {
            src_subresource: layers(aspects),
            src_offsets: from,
            dst_subresource: layers(aspects),
            dst_offsets: to,
        };
        let mut blits = Vec::new();
        let mut copies = Vec::new();
        match self.case {
            TransferCase::Blit | TransferCase::BlitSeparateLayouts => {
                let whole = [offset(0, 0, 0), offset(64, 64, 1)];
                let mirrored = [offset(64, 64, 0), offset(0, 0, 1)];
                for (k, &aspects) in aspect_sets.iter().enumerate() {
                    let x = 16 * k as i32;
                    blits.push(blit(
                        whole,
                        [offset(x, 0, 0), offset(x + 16, 16, 1)],
                        aspects,
                    ));
                    blits.push(blit(
                        mirrored,
                        [offset(x, 16, 0), offset(x + 16, 32, 1)],
                        aspects,
                    ));
                    let block = [offset(8 * k as i32, 40, 0), offset(8 * k as i32 + 8, 48, 1)];
                    blits.push(blit(
                        block,
                        [offset(x, 48, 0), offset(x + 8, 56, 1)],
                        aspects,
                    ));
                }
            }
            TransferCase::Blit3d => {
                let whole = [offset(0, 0, 0), offset(16, 16, 16)];
                for (k, &aspects) in aspect_sets.iter().enumerate() {
                    let x = 4 * k as i32;
                    let to = [offset(x, 0, 0), offset(x + 4, 4, 4)];
                    let from = if aspects == depth {
                        [offset(0, 0, 16), offset(16, 16, 0)]
                    } else {
                        whole
                    };
                    blits.push(blit(from, to, aspects));
                }
                for z in [0, 4, 8, 12] {
                    blits.push(blit(
                        [offset(4, 4, z), offset(8, 8, z + 4)],
                        [offset(12, 8, z), offset(16, 12, z + 4)],
                        depth,
                    ));
                }
            }
            TransferCase::Blit3dTo2d | TransferCase::BlitStencil3dTo2d => {
                for (k, &aspects) in aspect_sets.iter().enumerate() {
                    let x = 16 * k as i32;
                    let from = if aspects == depth {
                        [offset(0, 0, 16), offset(16, 16, 0)]
                    } else {
                        [offset(0, 0, 0), offset(16, 16, 16)]
                    };
                    blits.push(blit(
                        from,
                        [offset(x, 0, 0), offset(x + 16, 16, 1)],
                        aspects,
                    ));
                }
                for (k, z) in [0, 5, 10, 15].into_iter().enumerate() {
                    let x = 16 * k as i32;
                    blits.push(blit(
                        [offset(0, 0, z), offset(16, 16, z + 1)],
                        [offset(x, 32, 0), offset(x + 16, 48, 1)],
                        aspect_sets[0],
                    ));
                }
            }
            TransferCase::Copy3d => {
                for &aspects in &aspect_sets[..aspect_sets.len().min(2)] {
                    for i in [0, 4, 8, 12] {
                        copies.push(vk::ImageCopy {
                            src_subresource: layers(aspects),
                            src_offset: offset(i / 2, i / 4, 12 - i),
                            dst_subresource: layers(aspects),
                            dst_offset: offset(i, 12 - i, i),
                            extent: vk::Extent3D {
                                width: 4,
                                height: 4,
                                depth: 4,
                            },
                        });
                    }
                }
            }
            TransferCase::Copy3dTo2d | TransferCase::CopyStencil3dTo2d => {
                for &aspects in &aspect_sets[..aspect_sets.len().min(2)] {
                    for z in 0..16 {
                        copies.push(vk::ImageCopy {
                            src_subresource: layers(aspects),
                            src_offset: offset(0, 0, z),
                            dst_subresource: layers(aspects),
                            dst_offset: offset(16 * (z % 4), 16 * (z / 4), 0),
                            extent: vk::Extent3D {
                                width: 16,
                                height: 16,
                                depth: 1,
                            },
                        });
                    }
                }
            }
        }
        Regions { blits, copies }
    }

    /// Per destination texel, the aspects the case's regions write: bit 0 depth, bit 1
    /// stencil (`aspects.u8`). Where a region writes one aspect of a depth/stencil texel alone,
    /// lavapipe's blits write the other too (both aspects of a packed D24_S8 texel: not what
    /// the spec says), and what lands there is the driver's choice: the test compares each
    /// aspect where a region writes it, or none does.
    fn written_aspects(&self) -> Vec<u8> {
        let extent = self.destination.extent;
        let (w, h) = (extent.width as usize, extent.height as usize);
        let mut mask = vec![0u8; self.destination.texels()];
        let mut mark = |lo: vk::Offset3D, hi: vk::Offset3D, aspects: vk::ImageAspectFlags| {
            let bits = u8::from(aspects.contains(vk::ImageAspectFlags::DEPTH))
                | u8::from(aspects.contains(vk::ImageAspectFlags::STENCIL)) << 1;
            for z in lo.z..hi.z {
                for y in lo.y..hi.y {
                    for x in lo.x..hi.x {
                        mask[(z as usize * h + y as usize) * w + x as usize] |= bits;
                    }
                }
            }
        };
        let Regions { blits, copies } = self.regions();
        for b in &blits {
            let [a, c] = b.dst_offsets;
            let lo = offset(a.x.min(c.x), a.y.min(c.y), a.z.min(c.z));
            let hi = offset(a.x.max(c.x), a.y.max(c.y), a.z.max(c.z));
            mark(lo, hi, b.dst_subresource.aspect_mask);
        }
        for c in &copies {
            let o = c.dst_offset;
            // A 3D slice into a 2D image is one deep there.
            let depth = if extent.depth > 1 { c.extent.depth } else { 1 };
            let hi = offset(
                o.x + c.extent.width as i32,
                o.y + c.extent.height as i32,
                o.z + depth as i32,
            );
            mark(o, hi, c.dst_subresource.aspect_mask);
        }
        mask
    }

    /// The case's copy or blit, with the images in `src_layout` and `dst_layout`.
    fn record_case(
        &self,
        cmd: vk::CommandBuffer,
        src_layout: vk::ImageLayout,
        dst_layout: vk::ImageLayout,
    ) {
        let device = &self.gpu.device;
        let (src, dst) = (self.source.image, self.destination.image);
        let Regions { blits, copies } = self.regions();
        // SAFETY: both images in the layouts named, regions inside them (none overlapping in
        // the destination but where they name other aspects), NEAREST for depth/stencil;
        // a 3D slice into a 2D image is VK_KHR_maintenance1's, core in 1.1.
        unsafe {
            if !blits.is_empty() {
                device.cmd_blit_image(
                    cmd,
                    src,
                    src_layout,
                    dst,
                    dst_layout,
                    &blits,
                    vk::Filter::NEAREST,
                );
            }
            if !copies.is_empty() {
                device.cmd_copy_image(cmd, src, src_layout, dst, dst_layout, &copies);
            }
        }
    }
}
