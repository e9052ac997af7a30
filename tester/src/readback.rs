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
use crate::target::{full_range, DepthFormat, Targets};

/// Host-visible buffers receiving the color image and the depth aspect of the depth image.
#[derive(Debug)]
pub struct Readback<'a> {
    color: HostBuffer<'a>,
    /// None with `--no-depth-readback`.
    depth: Option<HostBuffer<'a>>,
    extent: vk::Extent2D,
    depth_format: DepthFormat,
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
    pub fn new(gpu: &'a Gpu, targets: &Targets<'_>, depth: bool) -> Result<Self> {
        let pixels = targets.pixel_count();
        let color = HostBuffer::new(gpu, pixels * 4, vk::BufferUsageFlags::TRANSFER_DST)
            .context("color read-back buffer")?;
        let depth = if depth {
            Some(
                HostBuffer::new(
                    gpu,
                    pixels * targets.depth_format.depth_copy_texel_size(),
                    vk::BufferUsageFlags::TRANSFER_DST,
                )
                .context("depth read-back buffer")?,
            )
        } else {
            None
        };
        Ok(Readback {
            color,
            depth,
            extent: targets.extent,
            depth_format: targets.depth_format,
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
        let extent = vk::Extent3D {
            width: self.extent.width,
            height: self.extent.height,
            depth: 1,
        };
        let region = |aspect| vk::BufferImageCopy {
            buffer_offset: 0,
            buffer_row_length: 0,
            buffer_image_height: 0,
            image_subresource: vk::ImageSubresourceLayers {
                aspect_mask: aspect,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            },
            image_offset: vk::Offset3D { x: 0, y: 0, z: 0 },
            image_extent: extent,
        };
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
        // the buffers are large enough for tightly packed copies of the whole images, and the
        // depth image has TRANSFER_SRC usage whenever a depth buffer exists.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
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
                &[region(vk::ImageAspectFlags::COLOR)],
            );
            if let Some(depth) = &self.depth {
                device.cmd_copy_image_to_buffer(
                    cmd,
                    targets.depth.image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    depth.buffer,
                    &[region(vk::ImageAspectFlags::DEPTH)],
                );
            }
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

    /// The read-back contents (call only after the render's fence has signalled).
    pub fn frame(&self) -> Result<Frame> {
        let pixels = self.extent.width as usize * self.extent.height as usize;
        let rgba = self.color.contents()[..pixels * 4].to_vec();
        let depth = match &self.depth {
            Some(depth) => Some(decode_depth(self.depth_format, depth.contents(), pixels)?),
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
