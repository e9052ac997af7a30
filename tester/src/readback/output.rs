//! What is done with what was read back: depth decoded to f32 for every depth format, its
//! statistics and visualisation, the render report, and the output files.

use super::*;

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
    /// The views rendered: 2 for the multiview scenes (each view into its own array layer of
    /// the color and depth images), 1 otherwise. View n > 0 has its own directory, `view<n>`
    /// ([`view_dir`]), with the same files for its layer, its ground truth seen from its own
    /// camera, and a `render.json` of its own.
    pub views: usize,
    /// The view whose files are in this directory (0 in the output directory itself).
    pub view: usize,
    /// Counted validation messages (0 without `--validation`).
    pub validation_messages: u32,
    /// Why `--validation` was left out of this render (a validation layer older than an
    /// extension the scene needs); absent where it ran or was not asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation_skipped: Option<String>,
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
    /// Whether it clamps depth (`depthClampEnable`).
    pub depth_clamp: bool,
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

/// The directory of view `view`'s files: `out` itself for view 0, `out/view<n>` for view n
/// (see [`RenderReport::views`]).
pub fn view_dir(out: &Path, view: usize) -> PathBuf {
    match view {
        0 => out.to_path_buf(),
        n => out.join(format!("view{n}")),
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
